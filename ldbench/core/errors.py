"""The one exception type the CLI turns into a single line on stderr and a non-zero exit."""


class LdbenchError(Exception):
    """A user-facing error: bad input, missing file, no suitable GPU.

    The message must be one line that names what was wrong (the scene, parameter, element, path).
    The CLI prints ``ldbench: error: <message>`` and exits with status 2; no traceback.
    """


class Interrupted(KeyboardInterrupt):
    """Ctrl-C after part of the work was kept: the message says what (the CLI prints ``ldbench: interrupted:
    <message>`` and exits with status 130), so that a rerun does not add the same rows twice."""


class Terminated(SystemExit):
    """SIGTERM, raised in the main thread by :func:`exit_on_sigterm` (exit status 15, as ``sys.exit(15)``): the
    run stops and deletes its partial folder. A ``SystemExit`` of any other kind inside a job is the plugin's
    own ``sys.exit()``, which becomes that job's error row instead of ending the run."""


def exit_on_sigterm(signum, frame):
    """A SIGTERM handler: raise :class:`Terminated` (``signal.signal(signal.SIGTERM, exit_on_sigterm)``)."""
    raise Terminated(signum)
