"""The studies wing: measurements and figures built on the library, one module per study.

* ``work_precision`` (+ ``work_precision_report``): error against wall time for every formulation x integrator
  x tolerance, with the seed-style baseline beside them; ``bench`` is the ``python -m physics bench`` command
  that dispatches to every suite.
* ``stability_study`` (+ ``stability_figures``): the five cases of docs/stability.md (``python -m physics.stability``).
* ``chaos_map``: time-to-first-flip maps of initial angles (``python -m physics chaos-map``).
* ``ensemble_bench``: throughput of batched ensembles (``bench --suite ensemble``).
* ``models``: the cheapest model for each question (``bench --suite models``).
* ``report``: progress bar, timing, machine note and report writer every study shares; ``charts``: SVG and
  PNG drawing; ``seed_baseline``: the seed report's approach ported to Python, the yardstick.

What a study may import: the core library (``physics.model``, ``physics.simulate`` ...), ``physics.arguments``,
``physics.outputs`` and other modules of this wing. The core never imports a study (the layer contract in
pyproject.toml, checked by ``lint-imports``). Nothing is imported here, so importing one study loads only what
it needs.
"""
