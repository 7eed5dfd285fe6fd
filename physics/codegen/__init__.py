"""Generated numeric code: emitted from the symbolic systems, cached on disk, loaded without sympy."""

from .cache import CompiledSystem, cache_dir, clear_memory_cache, load_compiled

__all__ = ["CompiledSystem", "cache_dir", "clear_memory_cache", "load_compiled"]
