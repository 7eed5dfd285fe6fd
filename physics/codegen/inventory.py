"""What the cache folder holds, and emptying it: ``python -m physics cache --info | --clear``."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

from ..cache_folder import cache_dir, configured_path

_ENTRY = re.compile(r"^(newton_euler|lagrange|dae)-n(\d+)-(open|pinned)-([0-9a-f]{16})\.py$")


def _size(paths) -> int:
    total = 0
    for path in paths:
        try:
            total += path.stat().st_size
        except OSError:
            pass
    return total


def cache_info() -> dict:
    """Where the cache is, the mechanisms it holds, and the bytes of each part."""
    folder = cache_dir()
    entries = []
    for path in sorted(folder.glob("*.py")):
        match = _ENTRY.match(path.name)
        if match:
            entries.append({"method": match[1], "links": int(match[2]), "closure": match[3], "digest": match[4],
                            "file": path.name, "bytes": _size([path])})
    numba = folder / "numba"
    native = folder / "native"  # physics.codegen.machine_code: the IR modules' object files
    generated = [p for p in (numba / "generated").glob("*") if p.is_file()] + [p for p in native.glob("*") if p.is_file()]
    kernels = [p for p in numba.rglob("*") if p.is_file() and "generated" not in p.parts]
    other = [p for p in folder.rglob("*") if p.is_file() and numba not in p.parents and native not in p.parents
             and not _ENTRY.match(p.name)]
    parts = {
        "generated_source": _size(folder / str(e["file"]) for e in entries),
        "generated_machine_code": _size(generated),
        "kernels_machine_code": _size(kernels),
        "other": _size(other),
    }
    return {
        "folder": str(folder),
        "configured": str(configured_path()),
        "mechanisms": entries,
        "bytes": parts,
        "total_bytes": sum(parts.values()),
    }


def clear_cache() -> dict:
    """Remove everything in the cache folder (the folder itself stays); returns what was removed."""
    info = cache_info()
    folder = Path(info["folder"])
    for path in folder.iterdir():
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            try:
                path.unlink()
            except OSError:
                pass
    return {"folder": info["folder"], "removed_mechanisms": len(info["mechanisms"]),
            "removed_bytes": info["total_bytes"]}


def describe(info: dict) -> str:
    """The info as lines a person reads."""
    mib = 1024 * 1024
    lines = [f"cache folder: {info['folder']}"]
    if info["folder"] != info["configured"]:
        lines.append(f"  (a private temporary folder: {info['configured']} was refused)")
    lines.append(f"mechanisms: {len(info['mechanisms'])}")
    for entry in info["mechanisms"]:
        lines.append(f"  {entry['method']} n={entry['links']} {entry['closure']}  ({entry['file']})")
    b = info["bytes"]
    lines.append(f"generated source {b['generated_source'] / mib:.2f} MiB, compiled mechanisms "
                 f"{b['generated_machine_code'] / mib:.2f} MiB, compiled kernels {b['kernels_machine_code'] / mib:.2f} "
                 f"MiB, other {b['other'] / mib:.2f} MiB; total {info['total_bytes'] / mib:.2f} MiB")
    return "\n".join(lines)
