"""Generated numeric code: emitted from the symbolic systems, cached on disk, loaded without sympy."""

from .cache import CompiledSystem, cache_dir, clear_memory_cache, load_compiled

__all__ = ["CompiledSystem", "cache_dir", "clear_memory_cache", "load_compiled"]
from .latex import equations_latex  # noqa: E402

__all__.append("equations_latex")
