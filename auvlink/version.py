"""The package version, in a module of its own: the layers below the application import it from here,
never from the root package ``auvlink`` (whose public facade reaches the application layer)."""

__version__ = "0.1.0"
