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
