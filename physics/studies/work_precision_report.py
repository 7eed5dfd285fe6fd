"""What the work-precision study leaves: one SVG per case, the JSON document, an HTML page and the Markdown
tables BENCHMARKS.md quotes.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

from .charts import html_page, html_table
from .report import format_seconds
from .work_precision import HEADLINE_CASE, HORIZON
from .work_precision_chart import chart, probe_name


def markdown_summary(document: dict) -> str:
    """The tables BENCHMARKS.md quotes: winners per case and the headline."""
    lines = []
    machine = document["machine"]
    lines.append(f"`{document.get('command', 'python -m physics bench')}`; machine: {machine['cpus']} CPUs, load "
                 f"average {machine['load_average_1_5_15']}, Python "
                 f"{machine['python']}; {document['time_definition']}.")
    for name, case in document["cases"].items():
        lines.append("")
        lines.append(f"**{name}** ({probe_name(case)} error at t = {case['horizon']:g} s; reference uncertainty "
                     f"{case['reference']['uncertainty']:.1e})")
        lines.append("")
        lines.append("| accuracy | fastest configuration | setting | time | runner-up | its time |")
        lines.append("| --- | --- | --- | --- | --- | --- |")
        for row in case["winners"]:
            if row["winner"] is None:
                lines.append(f"| {row['accuracy']:.0e} | {row.get('reason', 'not reached')} | | | | |")
                continue
            lines.append(
                f"| {row['accuracy']:.0e} | {row['winner']} | {row['knob']:g} | {format_seconds(row['seconds'])} | "
                f"{row['runner_up'] or '-'} | {format_seconds(row['runner_up_seconds'])} |"
            )
    if "headline" in document:
        lines.append("")
        lines.append(f"**Headline** ({HEADLINE_CASE}, tip error at t = {HORIZON[HEADLINE_CASE]:g} s): ours vs the "
                     "seed-style baseline, both measured in this run")
        lines.append("")
        lines.append("| accuracy | ours | time | baseline | time | speed-up |")
        lines.append("| --- | --- | --- | --- | --- | --- |")
        for row in document["headline"]:
            ours, base = row["ours"], row["baseline"]
            lines.append(
                f"| {row['accuracy']:.0e} | {ours['label'] + ' @ ' + format(ours['knob'], 'g') if ours else 'not reached'} | "
                f"{format_seconds(ours['seconds'] if ours else None)} | "
                f"{base['label'].split(' (sympy')[0] + ' @ ' + format(base['tolerance'], 'g') if base else 'not reached'} | "
                f"{format_seconds(base['seconds'] if base else None)} | "
                f"{format(row['speedup'], '.0f') + 'x' if row['speedup'] else '-'} |"
            )
    return "\n".join(lines) + "\n"


def _html(document: dict, charts: dict) -> str:
    sections = []
    if "headline" in document:
        rows = []
        for row in document["headline"]:
            ours, base = row["ours"], row["baseline"]
            rows.append([
                f"{row['accuracy']:.0e}",
                ours["label"] if ours else "not reached",
                format_seconds(ours["seconds"]) if ours else "-",
                base["label"].split(" (sympy")[0] + f" @ {base['tolerance']:g}" if base else "not reached",
                format_seconds(base["seconds"]) if base else "-",
                f"{row['speedup']:.0f}x" if row["speedup"] else "-",
            ])
        sections.append((f"Headline: {HEADLINE_CASE}, ours vs the seed-style baseline",
                         html_table(["accuracy", "ours (fastest)", "time", "baseline (fastest)", "time", "speed-up"], rows)))
    for name, case in document["cases"].items():
        rows = [[f"{r['accuracy']:.0e}", r["winner"] or r.get("reason", "not reached"), format_seconds(r.get("seconds")),
                 r.get("runner_up") or "-", format_seconds(r.get("runner_up_seconds"))] for r in case["winners"]]
        text = (f"<p>Reference: {case['reference']['description']}; uncertainty "
                f"{case['reference']['uncertainty']:.2e}. Horizon {case['horizon']:g} s.</p>")
        sections.append((f"{name}", charts[name] + text +
                         html_table(["accuracy", "fastest", "time", "runner-up", "time"], rows)))
    machine = document["machine"]
    intro = (f"Error: {document['error_definition']}. Time: {document['time_definition']}. Machine: "
             f"{machine['cpus']} CPUs, load average {machine['load_average_1_5_15']}. "
             f"Made by <code>{html.escape(document.get('command', 'python -m physics bench'))}</code> in "
             f"{document['elapsed_seconds']:.0f} s.")
    return html_page("Linkage Lab: work-precision", sections, intro)


def write_outputs(document: dict, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    written = []
    charts = {}
    for name, case in document["cases"].items():
        charts[name] = chart(name, case)
        path = out / f"work_precision_{name}.svg"
        path.write_text(charts[name])
        written.append(path)
    path = out / "work_precision.json"
    path.write_text(json.dumps(document, indent=1))
    written.append(path)
    path = out / "work_precision.html"
    path.write_text(_html(document, charts))
    written.append(path)
    path = out / "work_precision.md"
    path.write_text(markdown_summary(document))
    written.append(path)
    return written
