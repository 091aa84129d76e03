"""The exit statuses of every ``pfield`` command, so a script can tell a failed outcome from a wrong command.

====  ===========  =================================================================================================
code  name         meaning
====  ===========  =================================================================================================
0     ``OK``       done, and the outcome succeeded (a service response without a ``success`` field counts as done)
1     ``FAILED``   the command ran and its outcome failed; the same command may succeed later or in another state:
                   ``success: false`` in a service response, a ``batch`` problem in status ``error``, a ``plan``
                   that did not reach its goal, a ``sim2d`` run that ended otherwise than its scenario expects,
                   ``find-valid-pose`` finding only LETHAL, no message within ``--timeout``, the node or a Ray
                   cluster unreachable, the node busy (HTTP 408, 429, 5xx)
2     ``USAGE``    the command itself is wrong and was refused as given; repeating it cannot help: click's usage
                   errors (an unknown option, a missing argument), an invalid value, YAML argument, name or file,
                   a request the node refuses as given (HTTP 4xx but 408 and 429), ``serve`` on a port in use
====  ===========  =================================================================================================

click (under typer) already exits 2 for usage errors; pfield's own checks use the same code for the same reason.
docs/node.md ("Exit codes") is the user's copy of this table.
"""

from __future__ import annotations

__all__ = ["FAILED", "OK", "USAGE", "for_http_status"]

OK = 0
FAILED = 1
USAGE = 2


def for_http_status(status: int) -> int:
    """The exit code of a command whose request the node answered with HTTP ``status`` (>= 400): ``USAGE``
    when the request was refused as given (4xx), ``FAILED`` when it may pass later (408 timeout, 429 busy, 5xx)."""
    return USAGE if 400 <= status < 500 and status not in (408, 429) else FAILED
