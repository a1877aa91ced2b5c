"""The match keys of ``ldbench compare``, apart from the matching itself (pandas), so that the command's
arguments are built without importing it."""

#: Default match keys: one benchmark = one scene (with builder parameters), method, effect (with its
#: parameters), method parameters and image size.
DEFAULT_MATCH = ("scene", "scene_params", "method", "effect", "effect_params", "params", "width", "height")
#: Every column ``--match`` accepts.
MATCH_KEYS = DEFAULT_MATCH + ("suite", "scene_hash", "ref_spp")
