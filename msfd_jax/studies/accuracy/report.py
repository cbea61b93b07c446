"""The study's report: the markdown table, the fastest method within a tolerance, figures."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

# ----------------------------------------------------------------------------------------------
# Report


def markdown(result: dict[str, Any]) -> str:
    """The references and the rows as the markdown tables recorded in docs/accuracy.md."""
    lines = [
        "## References (Verlet, successive halvings)",
        "",
        "| case | metric | safeties | max diff between successive levels [K0] "
        "| observed order | estimated error of the reference [K0] | t_end | results |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in result["references"]:
        safeties = ", ".join(f"{lv['safety']:g}" for lv in r["levels"])
        diffs = ", ".join(f"{d:.1e}" for d in r["successive_differences"])
        t_end = ", ".join(f"{lv['t_end']:.3f}" for lv in r["levels"] if "t_end" in lv) or "-"
        results = ", ".join(dict.fromkeys(lv["result"] for lv in r["levels"]))
        lines.append(
            f"| {r['case']} | {r['metric']} | {safeties} | {diffs} "
            f"| {r['observed_order']:.2f} | {r['estimated_error']:.1e} | {t_end} | {results} |"
        )
    lines += [
        "",
        "## Runs",
        "",
        "| case | metric | method | parameter | error [K0] | all 7 fractions [K0] "
        "| median s | min s | steps | rejected | force evals | result | load (1 min) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in result["rows"]:
        loads = r["loadavg_1min"]
        load = f"{min(loads):.1f}-{max(loads):.1f}" if loads else "-"
        lines.append(
            f"| {r['case']} | {r['metric']} | {r['method']} | {r['parameter']} = {r['value']:g} "
            f"| {r['error']:.2e} | {r['error_all_fractions']:.2e} | {r['wall_median_s']:.3f} "
            f"| {r['wall_min_s']:.3f} | {r['steps']} | {r['rejected']} "
            f"| {r['force_evaluations']} | {r['result']} | {load} |"
        )
    return "\n".join(lines)


def fastest_within(
    rows: Sequence[dict[str, Any]], tolerance: float = 1e-3, metric: str = "at_stop"
) -> dict[str, Any]:
    """Per case, the fastest configuration (median time) with error <= tolerance."""
    best = {}
    for r in rows:
        if r["metric"] != metric or not r["ok"] or not r["error"] <= tolerance:
            continue
        key = r["case"]
        if key not in best or r["wall_median_s"] < best[key]["wall_median_s"]:
            best[key] = r
    return best


def plot(result: dict[str, Any], metric: str, path) -> None:
    """Log-log error against median wall time, one panel per collision."""
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    rows = [r for r in result["rows"] if r["metric"] == metric and r["ok"]]
    cases = list(dict.fromkeys(r["case"] for r in rows))
    fig = Figure(figsize=(4.2 * len(cases), 3.8), layout="constrained")
    axes = fig.subplots(1, len(cases), squeeze=False)[0]
    styles = {
        "verlet": ("o-", "C0"),
        "verlet_substeps1": ("s--", "C9"),
        "yoshida4": ("^-", "C1"),
        "tsit5_perzyna": ("D-", "C2"),
        "dopri5_perzyna": ("v-", "C4"),
        "tsit5_perzyna_eta": ("P", "C5"),
        "kvaerno5_perzyna": ("X-", "C3"),
        "yield_smoothing": ("*", "C6"),
        "contact_smoothing": ("h", "C7"),
    }
    for ax, case in zip(axes, cases, strict=True):
        for method in dict.fromkeys(r["method"] for r in rows if r["case"] == case):
            sel = sorted(  # along the method's parameter (step, tolerance, width)
                (r for r in rows if r["case"] == case and r["method"] == method),
                key=lambda r: r["value"],
            )
            t = [r["wall_median_s"] for r in sel]
            e = [max(r["error"], 1e-9) for r in sel]
            style, color = styles.get(method, (".-", "k"))
            ax.loglog(t, e, style, color=color, label=method, ms=5)
            if method == "verlet":
                for r in sel:
                    if r["value"] in (1.0, 0.8, 0.5, 0.25, 0.05):
                        ax.annotate(
                            f"{r['value']:g}",
                            (r["wall_median_s"], max(r["error"], 1e-9)),
                            fontsize=7,
                            xytext=(3, 3),
                            textcoords="offset points",
                        )
        ax.axhline(1e-3, color="gray", lw=0.8, ls=":")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(case)
        ax.set_xlabel("wall time, median [s]")
        ax.set_ylabel("max error [K0]")
    axes[-1].legend(fontsize=7, loc="best")
    fig.savefig(path, dpi=110)
