"""The compiled kernels release Python's GIL while they integrate (``nogil=True``).

Why: the app's players call a kernel from their own threads, and viser's websocket server runs on an asyncio
thread of the same process. A kernel that held the GIL for a long integrator call froze every other session and
the websocket keepalive with it (issue 23: under load a session's connection was closed during a stiff chain's
call). Both tests fail if the option is removed from a kernel.
"""

from __future__ import annotations

import importlib
import pkgutil
import threading
import time

from numba.core.registry import CPUDispatcher

import physics.kernels
from physics import get_preset, simulate
from physics.simulate.run import Settings


def _kernel_dispatchers():
    for info in pkgutil.iter_modules(physics.kernels.__path__):
        module = importlib.import_module(f"physics.kernels.{info.name}")
        for name, value in vars(module).items():
            if isinstance(value, CPUDispatcher) and value.__module__ == module.__name__:
                yield f"{module.__name__}.{name}", value


def test_every_compiled_kernel_is_declared_nogil():
    kernels = dict(_kernel_dispatchers())
    assert len(kernels) > 20, sorted(kernels)  # the integrators, the solves, the projection, the observables
    holding = sorted(name for name, dispatcher in kernels.items() if not dispatcher.targetoptions.get("nogil"))
    assert holding == [], f"these kernels hold the GIL while they run: {holding}"


def test_another_thread_runs_while_an_integration_is_inside_the_kernel():
    preset = get_preset("triple-a")
    settings = Settings(method="dae", integrator="DOP853", rtol=1e-11, atol=1e-11, t_end=3000.0, samples=11)

    def integrate():
        simulate(preset.chain, preset.theta0, preset.omega0, settings)

    integrate()  # compiled and loaded: what follows is the integration itself, almost all of it in one call
    worker = threading.Thread(target=integrate)
    ticks: list[float] = []
    worker.start()
    while worker.is_alive():
        ticks.append(time.perf_counter())
        time.sleep(0.001)
    worker.join()
    # Holding the GIL, the worker's one long kernel call lets this thread tick at most before and after it
    # (0 or 1 ticks were seen with the option removed); released, this thread ticks all along.
    assert len(ticks) >= 20, f"this thread ran {len(ticks)} times while the other integrated"
    largest_gap = max(b - a for a, b in zip(ticks, ticks[1:]))
    assert largest_gap < 0.5 * (ticks[-1] - ticks[0]), "this thread stood still for most of the integration"
