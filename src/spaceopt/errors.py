"""Project exceptions. Every message is one line naming the offending key and value."""


class SpaceoptError(Exception):
    """Base class: caught by the CLI and the workflow scripts and printed as one line."""


class ConfigError(SpaceoptError):
    """Bad input: ``key`` is the dotted config path, ``value`` what was given."""

    def __init__(self, key: str, value, reason: str):
        self.key, self.value, self.reason = key, value, reason
        super().__init__(f"{key}={value!r}: {reason}")


class ConvergenceError(SpaceoptError):
    """A continuation or Newton solve failed; ``diagnosis`` is a JSON-ready dict. ``end_point``:
    where a path reached its end but the final polish failed, the unconverged solution there
    (not serialised), for a caller that can certify it another way."""

    def __init__(self, message: str, diagnosis: dict):
        self.diagnosis = diagnosis
        self.end_point = None
        super().__init__(message)


class ArtifactError(SpaceoptError):
    """An artifact is missing, truncated or fails its checksum."""
