"""Domain errors: small classes whose message names the problem; the edges map them to 4xx/exit 1."""


class DomainError(Exception):
    """Base class for every error the core raises on bad input or an impossible request."""


class InvalidInput(DomainError):
    """A value is malformed or out of range (NaN, fov outside (0, 180), range <= 0, ...)."""


class InvalidFrustum(InvalidInput):
    """A frustum's field of view or range is not usable."""


class UnknownImage(DomainError):
    """An edit names an image the workspace or version does not have."""


class EmptyModel(DomainError):
    """A step needs a sparse model but there is none (mapping registered nothing)."""


class MissingWorkspace(DomainError):
    """A workspace directory or one of its required files does not exist."""


class Cancelled(DomainError):
    """The caller's cancellation token was set while a step ran."""
