"""The foundation of ldbench: errors, validated parameters, the GL context and its timing, scenes
and cameras, the effect specifications with the inputs they build, metrics, image I/O and
conventions. It imports nothing of ldbench above it (methods, references, harness, reports).
"""
