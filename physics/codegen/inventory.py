"""What the cache folder holds, and emptying it: ``python -m physics cache --info | --clear``."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

from ..cache_folder import cache_dir, configured_path, read_tagged

# A chain's own formulas (physics.codegen.load_compiled: the tests' oracle, benchmarks, the seed report)
_ENTRY = re.compile(r"^(newton_euler|lagrange|dae)-n(\d+)-(open|pinned)-([0-9a-f]{16})\.py$")
# A mechanism's generated system on the engine every linkage runs on (physics.mechanism.engine, tree_dae): its
# method, its pins' coordinates, its structure and the generator's digest; never its numbers
_MECHANISM = re.compile(r"^(newtoneuler|lagrange|dae|treedae)-mechanism-(absolute-)?([0-9a-f]{16})-([0-9a-f]{16})\.py$")
# A chain's record on that engine (physics.simulate.chain_record): which generated system runs the chain
_RECORD = re.compile(r"^chainroute-[a-z]+-n\d+-(open|pinned)-[0-9a-f]{16}\.json$")
_METHODS = {"newtoneuler": "newton_euler", "lagrange": "lagrange", "dae": "dae", "treedae": "dae"}


def _size(paths) -> int:
    total = 0
    for path in paths:
        try:
            total += path.stat().st_size
        except OSError:
            pass
    return total


def _chains_run_by(folder: Path) -> dict[str, tuple[int, str]]:
    """The generated systems' keys that a chain's record names, with that chain's links and closure (a record
    refused by the cache's trust rules names nothing: it is rebuilt at its next run)."""
    chains = {}
    for path in sorted(folder.glob("chainroute-*.json")):
        if not _RECORD.match(path.name):
            continue
        try:
            payload, problem = read_tagged(path)
            data = json.loads(payload) if problem is None and payload is not None else None
        except (OSError, ValueError):
            data = None
        if isinstance(data, dict) and isinstance(data.get("compiled_key"), str) and isinstance(data.get("n"), int):
            chains[data["compiled_key"]] = (data["n"], "pinned" if data.get("pinned") else "open")
    return chains


def cache_info() -> dict:
    """Where the cache is, the mechanisms it holds, and the bytes of each part.

    An entry is one generated system: a mechanism's on the engine (``structure`` its structure's digest,
    ``rotations`` what its pins' coordinates are; ``links`` and ``closure`` filled when a chain runs on it, else
    None) or a chain's own formulas (``structure`` None)."""
    folder = cache_dir()
    entries = []
    chains = _chains_run_by(folder)
    for path in sorted(folder.glob("*.py")):
        match = _ENTRY.match(path.name)
        if match:
            entries.append({"method": match[1], "links": int(match[2]), "closure": match[3], "structure": None,
                            "rotations": None, "digest": match[4], "file": path.name, "bytes": _size([path])})
            continue
        match = _MECHANISM.match(path.name)
        if match:
            key = path.name[: -len(f"-{match[4]}.py")]
            links, closure = chains.get(key, (None, None))
            entries.append({"method": _METHODS[match[1]], "links": links, "closure": closure, "structure": match[3],
                            "rotations": "absolute" if match[2] else "relative", "digest": match[4],
                            "file": path.name, "bytes": _size([path])})
    numba = folder / "numba"
    native = folder / "native"  # physics.codegen.machine_code: the IR modules' object files
    generated = [p for p in (numba / "generated").glob("*") if p.is_file()] + [p for p in native.glob("*") if p.is_file()]
    kernels = [p for p in numba.rglob("*") if p.is_file() and "generated" not in p.parts]
    other = [p for p in folder.rglob("*") if p.is_file() and numba not in p.parents and native not in p.parents
             and not _ENTRY.match(p.name) and not _MECHANISM.match(p.name)]
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
        if entry["structure"] is None:
            lines.append(f"  {entry['method']} n={entry['links']} {entry['closure']}, the chain's formulas  "
                         f"({entry['file']})")
        elif entry["links"] is not None:
            lines.append(f"  {entry['method']} n={entry['links']} {entry['closure']}  ({entry['file']})")
        else:
            lines.append(f"  {entry['method']} mechanism {entry['structure']}  ({entry['file']})")
    b = info["bytes"]
    lines.append(f"generated source {b['generated_source'] / mib:.2f} MiB, compiled mechanisms "
                 f"{b['generated_machine_code'] / mib:.2f} MiB, compiled kernels {b['kernels_machine_code'] / mib:.2f} "
                 f"MiB, other {b['other'] / mib:.2f} MiB; total {info['total_bytes'] / mib:.2f} MiB")
    return "\n".join(lines)
