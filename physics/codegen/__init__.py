"""Generated numeric code: emitted from the symbolic systems, cached on disk, loaded without sympy."""

from .cache import CompiledSystem, cache_dir, clear_memory_cache, load_compiled
from .latex import equations_latex

__all__ = ["CompiledSystem", "cache_dir", "clear_memory_cache", "equations_latex", "load_compiled"]
