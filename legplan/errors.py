"""Error types shared by every layer.

`LegplanError` is a user-facing error: bad input, unreadable file, invalid spec. The CLI prints its
message on one line and exits with code 2; `-v` adds the traceback. Anything else is a bug.
"""


class LegplanError(Exception):
    """Bad input: the message names the file and the field that is wrong."""


class ArtefactError(LegplanError):
    """An artefact file is missing, unreadable, of the wrong kind or schema, or incomplete."""


class SpecError(LegplanError):
    """A YAML/CSV/JSON input spec is invalid; the message names the file and the field."""


def did_you_mean(word: str, choices, cutoff: float = 0.6) -> str:
    """`" (did you mean 'x'?)"` naming the choices closest to `word` (case-insensitive, at most
    two), or "" when none is close: the hint of every unknown name (robots, commands)."""
    import difflib

    by_lower = {}
    for choice in choices:
        by_lower.setdefault(str(choice).lower(), str(choice))
    close = difflib.get_close_matches(str(word).lower(), list(by_lower), n=2, cutoff=cutoff)
    return f" (did you mean {' or '.join(repr(by_lower[c]) for c in close)}?)" if close else ""
