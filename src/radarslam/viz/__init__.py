"""Plots (matplotlib is imported only here, and only when a plot is asked for)."""


def have_matplotlib() -> bool:
    """Whether the ``viz`` extra is installed."""
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True
