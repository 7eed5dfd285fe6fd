"""A chain's route on the mechanism engine without the mechanism package: the per-structure record of what
:func:`physics.simulate.mechanism_route.chain_route` derives, kept beside the generated code, and the chain's
numbers mapped straight into the mechanism's parameter vector and observables (issue 24, "one pipeline").

Why: a warm process on the route used to import :mod:`physics.mechanism` (its pydantic models and frozen
dataclasses, ~40 ms) only to rebuild, from the chain written as a mechanism, pieces that hold no number of the
chain. Everything the run reads is either

* number-free, the same for every chain of one method, number of bars and pin (the structure): the generated
  system's cache key, the spanning tree's order, the reaction rows of the pins, the closed form of the reactions
  (:mod:`physics.mechanism.tree_reactions`) and the pins' damper Jacobian. They are this module's
  :class:`ChainRecord`, written once per structure (JSON, never pickle) in the private cache folder with an
  HMAC trailer (:mod:`physics.cache_folder`), named by a digest of the sources that produce them; or
* linear in the chain's numbers, read here as :func:`physics.mechanism.chains.chain_mechanism` and
  :func:`physics.mechanism.parameters.parameter_vector` would (the chain drawn hanging down at ``theta = 0``):
  :func:`parameter_vector`, :func:`mass_diagonal`, :func:`gravity_force`, :func:`sketch_points`.

The tests (tests/physics/test_chain_record.py) hold the two ways to each other bit for bit. This module imports
no :mod:`physics.mechanism` module (so the record route does not either).
"""

from __future__ import annotations

import hashlib
import json
import threading
from pathlib import Path

import numpy as np

from ..cache_folder import cache_dir, discard, read_tagged, tagged, warn
from ..file_io import write_atomically
from ..kinematics import com_positions, joint_positions
from ..model import Chain

__all__ = ["ChainRecord", "load_record", "parameter_vector", "record_digest", "save_record"]

FORMAT = 1
_PACKAGE_ROOT = Path(__file__).resolve().parent.parent
# What shapes a record: the mechanism package (the chain's description, its analysis, its reactions' closed form,
# the generated systems' keys), the chain's kinematics and model, the route and this module. The generated code
# itself has its own digest (physics.codegen.cache.generator_digest), part of the record's key through its name.
_SOURCE_PATTERNS = ("mechanism/*.py", "mechanism/joints/*.py", "kinematics.py", "model.py",
                    "simulate/chain_record.py", "simulate/mechanism_route.py")
_digest_memo: list[str] = []
_lock = threading.Lock()


def record_digest() -> str:
    """Digest of every source file that produces a record (read from the files themselves, once a process)."""
    if _digest_memo:
        return _digest_memo[0]
    h = hashlib.sha256(f"chain record {FORMAT}".encode())
    for pattern in _SOURCE_PATTERNS:
        for path in sorted(_PACKAGE_ROOT.glob(pattern)):
            h.update(str(path.relative_to(_PACKAGE_ROOT)).encode() + b"\0")
            h.update(path.read_bytes())
    _digest_memo.append(h.hexdigest()[:16])
    return _digest_memo[0]


def _stem(method: str, n: int, pinned: bool) -> str:
    return f"chainroute-{method.replace('_', '')}-n{n}-{'pinned' if pinned else 'open'}"


def record_path(method: str, n: int, pinned: bool) -> Path:
    """Where the record of a structure is in the private cache folder."""
    return cache_dir() / f"{_stem(method, n, pinned)}-{record_digest()}.json"


class ChainRecord:
    """The number-free pieces of a chain's route for one method, number of bars ``n`` and pin.

    ``compiled_key``, ``formulation``: the generated system (:func:`physics.codegen.cache.load_generated`);
    ``order``: tree coordinate k is the angle of bar ``order[k]``; ``joint_rows`` (2 n), ``tip_rows``: the
    reaction rows of pins O, J1 .. J(n-1) and H; ``own_reactions``: the system's multipliers are the reactions
    (the DAE); ``linear``, ``unknowns_map``: the observables plan's closed form of the chosen rows;
    ``damper_jacobian (n + pinned, 3 n)``: the gradient of each pin's damper's relative spin (pins O,
    J1 .. J(n-1), damped by the chain's damping, then H, undamped)."""

    def __init__(self, method: str, n: int, pinned: bool, compiled_key: str, formulation: str, order: np.ndarray,
                 joint_rows: np.ndarray, tip_rows: np.ndarray, own_reactions: bool, linear: np.ndarray,
                 unknowns_map: np.ndarray, damper_jacobian: np.ndarray) -> None:
        self.method, self.n, self.pinned = method, n, pinned
        self.compiled_key, self.formulation = compiled_key, formulation
        self.order = order
        self.joint_rows, self.tip_rows = joint_rows, tip_rows
        self.own_reactions = own_reactions
        self.linear, self.unknowns_map = linear, unknowns_map
        self.damper_jacobian = damper_jacobian

    def to_json(self) -> str:
        def array(values: np.ndarray) -> dict:
            return {"shape": list(values.shape), "values": values.ravel().tolist()}

        return json.dumps({
            "format": FORMAT, "method": self.method, "n": self.n, "pinned": self.pinned,
            "compiled_key": self.compiled_key, "formulation": self.formulation, "order": self.order.tolist(),
            "joint_rows": self.joint_rows.tolist(), "tip_rows": self.tip_rows.tolist(),
            "own_reactions": self.own_reactions, "linear": array(self.linear),
            "unknowns_map": array(self.unknowns_map), "damper_jacobian": array(self.damper_jacobian),
        }, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: bytes, method: str, n: int, pinned: bool) -> ChainRecord:
        """The record in ``text``, checked against the structure asked for; ValueError says what is wrong."""
        data = json.loads(text)
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise ValueError("another format")
        if (data.get("method"), data.get("n"), data.get("pinned")) != (method, n, pinned):
            raise ValueError("another structure")
        key, formulation = data.get("compiled_key"), data.get("formulation")
        if not (isinstance(key, str) and key.replace("-", "").isalnum() and isinstance(formulation, str)):
            raise ValueError("no generated system's key")

        def integers(name: str, size: int, bound: int) -> np.ndarray:
            values = data.get(name)
            if (not isinstance(values, list) or len(values) != size
                    or not all(type(v) is int and 0 <= v < bound for v in values)):
                raise ValueError(f"{name}: not {size} indices below {bound}")
            return np.array(values, dtype=np.int64)

        def floats(name: str, rows: int | None, columns: int) -> np.ndarray:
            entry = data.get(name)
            shape = entry.get("shape") if isinstance(entry, dict) else None
            values = entry.get("values") if isinstance(entry, dict) else None
            if (not isinstance(shape, list) or len(shape) != 2 or not all(type(v) is int and v >= 0 for v in shape)
                    or (rows is not None and shape[0] != rows) or shape[1] != columns
                    or not isinstance(values, list) or len(values) != shape[0] * shape[1]
                    or not all(type(v) in (int, float) for v in values)):
                raise ValueError(f"{name}: not a ({rows}, {columns}) array")
            return np.array(values, dtype=np.float64).reshape(shape)

        order = integers("order", n, n)
        if sorted(order.tolist()) != list(range(n)):
            raise ValueError("order: not a permutation of the bars")
        own = data.get("own_reactions")
        if type(own) is not bool:
            raise ValueError("own_reactions: not true or false")
        rows = 2 * n + 2 * pinned  # every pin's two rows
        joint_rows = integers("joint_rows", 2 * n, rows)
        tip_rows = integers("tip_rows", 2 * pinned, rows)
        chosen = 2 * n + 2 * pinned
        return cls(method, n, pinned, key, formulation, order, joint_rows, tip_rows, own,
                   floats("linear", 3 * n, chosen), floats("unknowns_map", None, chosen),
                   floats("damper_jacobian", n + pinned, 3 * n))


_records: dict[tuple[str, int, bool], ChainRecord] = {}


def load_record(method: str, n: int, pinned: bool) -> ChainRecord | None:
    """The structure's record from memory or the cache folder, or None (no record, or one not trusted: then
    discarded, with one line saying why, and rebuilt by the caller)."""
    key = (method, n, pinned)
    found = _records.get(key)
    if found is not None:
        return found
    path = record_path(method, n, pinned)
    try:
        payload, problem = read_tagged(path)
    except FileNotFoundError:
        return None
    if payload is not None:
        try:
            record = ChainRecord.from_json(payload, method, n, pinned)
        except ValueError as error:  # json's JSONDecodeError and UnicodeDecodeError are ValueErrors
            problem = f"unreadable: {error}"
        else:
            with _lock:
                _records[key] = record
            return record
    warn(f"chain route record {path} is not trusted ({problem}); discarded and rebuilt")
    discard(path)
    return None


def save_record(record: ChainRecord) -> None:
    """Write ``record`` (atomically, 0600, with its MAC) and remove the records of the same structure from other
    versions of the sources; a folder that cannot be written only costs the next process the full route."""
    path = record_path(record.method, record.n, record.pinned)
    try:
        write_atomically(path, tagged(path.name, record.to_json().encode()), mode=0o600)
    except OSError as error:
        warn(f"chain route record {path} could not be written ({error.strerror or error})")
        return
    with _lock:
        _records[(record.method, record.n, record.pinned)] = record
    for stale in path.parent.glob(f"{_stem(record.method, record.n, record.pinned)}-*.json"):
        if stale != path:
            discard(stale)


def forget() -> None:
    """Forget the records read so far (tests that change the cache folder or a record on disk)."""
    with _lock:
        _records.clear()


def parameter_vector(chain: Chain, damping: float, t: float = 0.0) -> np.ndarray:
    """:func:`physics.mechanism.parameters.parameter_vector` of ``chain_mechanism(chain, 0, damping)`` from the
    chain's numbers: per bar ``[m, I, cx, cy]`` (its centre hanging down), per pin its two arms (a point minus
    its bar's centre; the ground's point itself) and its damping, then ``g`` and ``t``."""
    n = chain.n
    zero = np.zeros(n)
    joints = joint_positions(chain.array("L"), zero)  # O, then each bar's distal point
    centres = com_positions(chain.params(), zero)
    m, inertia = chain.array("m"), chain.array("I")
    values: list[float] = []
    for k in range(n):
        values += [float(m[k]), float(inertia[k]), float(centres[k][0]), float(centres[k][1])]
    c = float(damping)
    values += [float(joints[0][0]) - centres[0][0], float(joints[0][1]) - centres[0][1], 0.0, 0.0, c]
    for k in range(1, n):  # Jk: bar k+1's P, bar k's D
        values += [float(joints[k][0]) - centres[k][0], float(joints[k][1]) - centres[k][1],
                   float(joints[k][0]) - centres[k - 1][0], float(joints[k][1]) - centres[k - 1][1], c]
    if chain.pin is not None:  # H: bar n's D, the ground's H; no damper
        values += [float(joints[n][0]) - centres[n - 1][0], float(joints[n][1]) - centres[n - 1][1],
                   float(chain.pin[0]), float(chain.pin[1]), 0.0]
    values += [float(chain.g), float(t)]
    return np.array(values, dtype=np.float64)


def mass_diagonal(chain: Chain) -> np.ndarray:
    """The bodies' mass matrix diagonal ``(m, m, I)`` per bar, as the mechanism's DAE holds it."""
    return np.array([float(v) for bar in chain.bars for v in (bar.m, bar.m, bar.I)])


def gravity_force(chain: Chain) -> np.ndarray:
    """Gravity on the bodies ``(0, -m g, 0)`` per bar, as the mechanism's DAE holds it."""
    force = np.zeros(3 * chain.n)
    force[1::3] = -float(chain.g) * np.array([float(bar.m) for bar in chain.bars])
    return force


def sketch_points(chain: Chain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each bar's proximal point ``P``, distal point ``D`` and centre ``(n, 2)`` in the sketch (hanging down)."""
    zero = np.zeros(chain.n)
    joints = joint_positions(chain.array("L"), zero)
    centres = com_positions(chain.params(), zero)
    return joints[:-1].copy(), joints[1:].copy(), centres
