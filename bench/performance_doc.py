#!/usr/bin/env python3
"""Regenerate the measured tables of docs/PERFORMANCE.md from `palplab bench --json` output.

Usage (what `make bench-doc` runs after a full `palplab bench`):
  python3 bench/performance_doc.py out/bench/bench.json [MORE.json ...] \
      --doc docs/PERFORMANCE.md --run-info out/bench/run_info.txt

Every block of the document between `<!-- generated:NAME -->` and `<!-- /generated:NAME -->`
is replaced: NAME is `run` (the run's date, commit, command and machine load from --run-info) or
a bench section (`search`, `frontier`, ...). The prose around the blocks is not touched: it was
written for the numbers of the run it cites and must be reread after a regeneration. With more
than one JSON file, a section in a later file replaces the same section of an earlier one (e.g.
a frontier-only rerun). Python 3 standard library only: a maintenance tool, not needed by the
build or the tests.
"""
import argparse
import json
import math
import re
import sys


def g(x, digits=3):
    """A number with `digits` significant digits (no exponent for ordinary magnitudes)."""
    if x is None:
        return ""
    if isinstance(x, bool):
        return str(int(x))
    if not isinstance(x, (int, float)) or not math.isfinite(x):
        return str(x)
    if x == 0:
        return "0"
    if 1e-3 <= abs(x) < 1e6:
        return f"{x:.{digits}g}"
    return f"{x:.{digits - 1}e}"


def us(s):
    return g(s * 1e6) if s else ""


def generic_table(section):
    rows = ["| case | reps | median | min | max | median CPU | metrics |",
            "|---|---|---|---|---|---|---|"]
    for r in section["results"]:
        m = r.get("metrics", {})
        mt = ", ".join(f"{k} {g(v)}" for k, v in m.items())
        timed = r.get("reps", 0) >= 1 and r.get("median_s", 0) > 0
        rows.append("| {} | {} | {} | {} | {} | {} | {} |".format(
            r["name"], r.get("reps", 0),
            g(r["median_s"]) + " s" if timed else "",
            g(r["min_s"]) if timed else "", g(r["max_s"]) if timed else "",
            g(r.get("median_cpu_s")) if timed else "", mt))
    return "\n".join(rows)


def frontier_tables(section):
    res = section["results"]
    models, refs = [], []
    for r in res:
        name, m = r["name"], r.get("metrics", {})
        if name.endswith("_reference"):
            refs.append(r)
            continue
        region = next((x for x in ("ovary_left", "horn_right", "body") if name.startswith(x + "_")),
                      name.split("_")[0])
        model = name[len(region) + 1:]
        models.append((region, model, r, m))
    out = ["| region | model | step µs median | p99 µs | (a) curve | (b) field | felt curve | "
           "settle | reference trusted |",
           "|---|---|---|---|---|---|---|---|---|"]
    for region, model, r, m in models:
        if model == "planted_20pct":
            out.append(f"| {region} | planted 20 % (control) | | | {g(m['force_curve_rel_err'])} | "
                       f"{g(m['field_rel_err'])} | | | |")
            continue
        if model == "fem_level0":
            out.append(f"| {region} | FEM level 0 (static solve) | {us(r['median_s'])} | | "
                       f"{g(m['force_curve_rel_err'])} | (max-norm {g(m['level0_field_max_err'])}) "
                       "| | | |")
            continue
        out.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            region, model, us(r["median_s"]), us(m.get("p99_step_s")),
            g(m.get("force_curve_rel_err")), g(m.get("field_rel_err")),
            g(m.get("felt_curve_rel_err")), g(m.get("settle_rel")),
            "yes" if m.get("ref_trusted", 0) else "**no**"))
    # Same-run ratios against D (median step time) per region.
    ratio = ["", "Same-run ratios of median step time to D's (per region):", "",
             "| region | " + " | ".join(["A", "B", "C", "C_full", "D_condensed", "D_corot"]) + " |",
             "|---|" + "---|" * 6]
    for region in dict.fromkeys(x[0] for x in models):
        t = {model: r["median_s"] for reg, model, r, m in models if reg == region}
        d = t.get("D")
        if not d:
            continue
        ratio.append(f"| {region} | " + " | ".join(
            g(t[k] / d) if t.get(k) else "" for k in
            ["A", "B", "C", "C_full", "D_condensed", "D_corot"]) + " |")
    ref = ["", "| region | levels | finest tets | k_ref N/m | extrapolated | order | finest vs ref "
           "| mesh under the press: D / level 0 mm | 1/k_ref (sᵀGs) m/N | wᵀGs m/N | time s | "
           "trusted (reason) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in refs:
        m = r["metrics"]
        why = r["what"].split(": ", 2)[-1] if "NOT TRUSTED" in r["what"] else "yes"
        why = why.replace("NOT TRUSTED: ", "**no**: ")
        ref.append("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |".format(
            r["name"][: -len("_reference")], "nested" if m.get("nested") else "TetGen",
            g(m.get("finest_level_tets")), g(m.get("k_ref_N_per_m")), g(m.get("ref_extrapolated")),
            g(m.get("ref_order")), g(m.get("finest_vs_ref_rel")),
            (g(1e3 * m.get("press_h_on_D_m", 0)) + " / " + g(1e3 * m["press_h_level0_m"]))
            if "press_h_level0_m" in m else "",
            g(m.get("c_ss_m_per_N")), g(m.get("c_ws_m_per_N")), g(r["median_s"]), why))
    return "\n".join(out + ratio + ref)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[1])
    ap.add_argument("json", nargs="+")
    ap.add_argument("--doc", default="docs/PERFORMANCE.md")
    ap.add_argument("--run-info", help="text file: date, commit, command, uptime before/after")
    a = ap.parse_args()
    sections = {}
    for f in a.json:
        with open(f) as fh:
            sections.update(json.load(fh))
    with open(a.doc) as fh:
        doc = fh.read()
    blocks = {}
    if a.run_info:
        with open(a.run_info) as fh:
            blocks["run"] = "```\n" + fh.read().strip() + "\n```"
    for name, sec in sections.items():
        quick = " (`--quick`)" if sec.get("quick") else ""
        body = frontier_tables(sec) if name == "frontier" else generic_table(sec)
        blocks[name] = f"Generated from bench.json{quick} by bench/performance_doc.py:\n\n{body}"
    done = []
    for name, text in blocks.items():
        pat = re.compile(r"(<!-- generated:%s -->\n).*?(<!-- /generated:%s -->)" %
                         (re.escape(name), re.escape(name)), re.S)
        if pat.search(doc):
            doc = pat.sub(lambda mo: mo.group(1) + text + "\n" + mo.group(2), doc)
            done.append(name)
    with open(a.doc, "w") as fh:
        fh.write(doc)
    missing = sorted(set(blocks) - set(done))
    print("regenerated:", ", ".join(done) or "nothing",
          ("; no block in the document for: " + ", ".join(missing)) if missing else "")
    return 0


if __name__ == "__main__":
    sys.exit(main())
