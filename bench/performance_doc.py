#!/usr/bin/env python3
"""Regenerate the measured tables of docs/PERFORMANCE.md from `palplab bench --json` output.

Usage (what `make bench-doc` runs after a full `palplab bench`):
  python3 bench/performance_doc.py out/bench/bench.json [MORE.json ...] \
      --doc docs/PERFORMANCE.md --run-info out/bench/run_info.txt

Every block of the document between `<!-- generated:NAME -->` and `<!-- /generated:NAME -->`
is replaced: NAME is `run` (the run's date, commit, command and machine load from --run-info),
a bench section (`search`, `frontier`, ...: every case, with median/min as the noise measure) or
SECTION_summary (the section's compact table: a pivot of the same cases, the SPEC's figures
beside them where it has some, a dagger on noisy medians). The prose around the blocks is not touched: it was
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


# A timed case is flagged noisy when its median is more than NOISY x its fastest repetition:
# on the shared machine the other processes' load then moved the median (the work itself is
# deterministic), so its absolute value and the ratios built on it are uncertain by that much.
NOISY = 1.5


def spread(r):
    """median / min of a timed case (1 = every repetition alike), or None when not timed."""
    if r.get("reps", 0) < 1 or not r.get("median_s") or not r.get("min_s"):
        return None
    return r["median_s"] / r["min_s"]


def noise_mark(r):
    sp = spread(r)
    if sp is None:
        return ""
    return f"**{g(sp, 2)} noisy**" if sp > NOISY else g(sp, 2)


def generic_table(section):
    rows = ["| case | reps | median | min | max | median CPU | median/min | metrics |",
            "|---|---|---|---|---|---|---|---|"]
    for r in section["results"]:
        m = r.get("metrics", {})
        mt = ", ".join(f"{k} {g(v)}" for k, v in m.items())
        timed = r.get("reps", 0) >= 1 and r.get("median_s", 0) > 0
        rows.append("| {} | {} | {} | {} | {} | {} | {} | {} |".format(
            r["name"], r.get("reps", 0),
            g(r["median_s"]) + " s" if timed else "",
            g(r["min_s"]) if timed else "", g(r["max_s"]) if timed else "",
            g(r.get("median_cpu_s")) if timed else "", noise_mark(r) if timed else "", mt))
    return "\n".join(rows)


def by_name(section):
    return {r["name"]: r for r in section["results"]}


def noisy_cell(r, value):
    """value, with a dagger when the case is noisy (median > NOISY x min)."""
    sp = spread(r)
    return value + (" †" if sp is not None and sp > NOISY else "")


NOISE_NOTE = ("† noisy: median > {}× the fastest repetition (the shared machine's load; "
              "the median/min column of the full table below).").format(NOISY)

# The original work's figures (SPEC §3; Pentium IV 2.0 GHz, units as printed there).
SPEC_SEARCH = {"tract1052": "994 vertices: 1.05 / 0.17 ms", "tract14422": "14392: 14.84 / 1.10 ms"}
SPEC_SCOPE = {1448: "0.90 / 3.8 µs (1442)", 8690: "2.70 / 21.5 µs (8664)"}


def search_summary(section):
    rs = by_name(section)
    variants = [("linear", "linear"), ("octree_d10_l8", "octree d10, ≤ 8/leaf"),
                ("octree_d10_l2", "d10, ≤ 2/leaf"), ("octree_d10_l32", "d10, ≤ 32/leaf"),
                ("octree_d4_l8", "d4, ≤ 8/leaf")]
    cases = list(dict.fromkeys(n.split("_linear")[0] for n in rs if n.endswith("_linear")))
    out = ["Per query, µs (median):", "",
           "| mesh | vertices | " + " | ".join(v[1] for v in variants) +
           " | linear / best octree | mismatches | SPEC linear / octree (P4) |",
           "|---|---|" + "---|" * len(variants) + "---|---|---|"]
    for c in cases:
        cells, octs, mism, nv = [], [], 0, ""
        for v, _ in variants:
            r = rs.get(c + "_" + v)
            if not r:
                cells.append("")
                continue
            m = r.get("metrics", {})
            nv = g(m.get("vertices"), 5)
            mism += m.get("mismatches", 0)
            cells.append(noisy_cell(r, g(r["median_s"] * 1e6)))
            if v != "linear":
                octs.append(r["median_s"])
        lin = rs[c + "_linear"]["median_s"]
        out.append(f"| {c} | {nv} | " + " | ".join(cells) +
                   f" | {g(lin / min(octs)) if octs else ''} | {g(mism)} | {SPEC_SEARCH.get(c, '')} |")
    return "\n".join(out + ["", NOISE_NOTE])


def haptic_scope_summary(section):
    rs = by_name(section)
    sizes = list(dict.fromkeys(int(n[1:].split("_")[0]) for n in rs if n.startswith("B")))
    out = ["Median over contact steps, µs per haptic step:", "",
           "| vertices | rings | octant | whole | whole / rings | SPEC rings / whole (P4) |",
           "|---|---|---|---|---|---|"]
    for v in sizes:
        r = {k: rs.get(f"B{v}_{k}") for k in ("rings", "octant", "whole")}
        cell = {k: noisy_cell(x, g(x["median_s"] * 1e6)) if x else "" for k, x in r.items()}
        ratio = g(r["whole"]["median_s"] / r["rings"]["median_s"]) if r["whole"] and r["rings"] else ""
        out.append(f"| {v} | {cell['rings']} | {cell['octant']} | {cell['whole']} | {ratio} | "
                   f"{SPEC_SCOPE.get(v, '')} |")
    return "\n".join(out + ["", NOISE_NOTE])


def refinement_summary(section):
    rs = by_name(section)
    models = [n[: -len("_refine_event")] for n in rs if n.endswith("_refine_event")]
    out = ["Mean over the touched nodes; haptic / graphics step after adaptive refinement at one node "
           "vs after refining the whole mesh to the level reached there (ms, median):", "",
           "| model | coarse nodes | A_t (m²) | new nodes area / conv. | new springs area / conv. | "
           "springs adaptive / whole model | haptic adaptive / whole (ms) | graphics adaptive / whole "
           "(ms) |",
           "|---|---|---|---|---|---|---|---|"]
    for mdl in models:
        ev = rs[mdl + "_refine_event"]
        m = ev["metrics"]
        at = re.search(r"A_t ([0-9.eE+-]+)", ev["what"])
        ha, hw = rs.get(mdl + "_haptic_adaptive"), rs.get(mdl + "_haptic_whole")
        ga, gw = rs.get(mdl + "_graphics_adaptive"), rs.get(mdl + "_graphics_whole")

        def pair(a, b):
            if not a or not b:
                return ""
            return "{} / {} ({}×)".format(noisy_cell(a, g(a["median_s"] * 1e3)),
                                          noisy_cell(b, g(b["median_s"] * 1e3)),
                                          g(b["median_s"] / a["median_s"]))
        springs = ""
        if ha and hw:
            springs = "{} / {}".format(g(ha["metrics"].get("springs"), 5),
                                       g(hw["metrics"].get("springs"), 5))
        out.append("| {} | {} | {} | {} / {} | {} / {} | {} | {} | {} |".format(
            mdl, g(m.get("coarse_nodes"), 5), g(float(at.group(1))) if at else "",
            g(m.get("area_new_nodes")), g(m.get("conv_new_nodes")),
            g(m.get("area_new_springs")), g(m.get("conv_new_springs")), springs, pair(ha, hw),
            pair(ga, gw)))
    out += ["| SPEC stomach (P4) | | | 81 / 91 | 214 / 234 | | 0.06 / 3.97 | 3.43 / 29.40 |",
            "| SPEC tract (P4) | | | | | | 0.08 / 15.45 | 5.40 / 110.6 |"]
    return "\n".join(out + ["", NOISE_NOTE])


def integrators_summary(section):
    rs = by_name(section)
    hs, methods = [], {}
    for n, r in rs.items():
        mo = re.match(r"(soft|stiff)_(.+)_h([0-9.]+)$", n)
        if mo:
            ms = methods.setdefault(mo.group(1), [])
            if mo.group(2) not in ms:
                ms.append(mo.group(2))
            if mo.group(3) not in hs:
                hs.append(mo.group(3))
    out = []
    for tissue, ms in methods.items():
        out += ["", f"{tissue} tissue — µs per step / relative error (`unstable`: diverged):", "",
                f"| {tissue} | " + " | ".join(f"h = {h} ms" for h in hs) + " | largest stable h |",
                "|---|" + "---|" * (len(hs) + 1)]
        for me in ms:
            cells = []
            for h in hs:
                r = rs.get(f"{tissue}_{me}_h{h}")
                if not r:
                    cells.append("")
                elif not r["metrics"].get("stable"):
                    cells.append("unstable")
                else:
                    cells.append(noisy_cell(r, "{} / {}".format(g(r["median_s"] * 1e6),
                                                                g(r["metrics"].get("rel_error"), 2))))
            ls = rs.get(f"{tissue}_{me}_largest_stable_h", {}).get("metrics", {})
            lsh = ls.get("largest_stable_h_s")
            out.append(f"| {me.replace('_', ' ')} | " + " | ".join(cells) + " | " +
                       (("none tested" if lsh == 0 else g(lsh * 1e3) + " ms") if lsh is not None
                        else "") + " |")
    return "\n".join(out[1:] + ["", NOISE_NOTE])


def sleeping_summary(section):
    out = ["| region | variant | mean step ms (median over presses) | median step µs | speed-up | "
           "awake max | force error | deformation error µm |",
           "|---|---|---|---|---|---|---|---|"]
    last = None
    for r in section["results"]:
        region = next((x for x in ("ovary_left", "horn_right", "body") if r["name"].startswith(x)),
                      r["name"].split("_")[0])
        m = r.get("metrics", {})
        full = r["name"] == region + "_full"
        out.append("| {} | {} | {} | {} | {} | {} | {} | {} |".format(
            region if region != last else "", r["name"][len(region) + 1:],
            noisy_cell(r, g(r["median_s"] * 1e3)),
            g(m["median_step_s"] * 1e6) if "median_step_s" in m else "",
            g(m.get("speedup")), g(m.get("awake_max"), 4),
            "—" if full else g(100 * m.get("force_rel_err", 0)) + " %",
            "—" if full else g(m.get("deformation_err_m", 0) * 1e6)))
        last = region
    return "\n".join(out + ["", NOISE_NOTE])


def throughput_summary(section):
    out = ["| case | median wall s (min–max) | × real time | peak RSS MB | DB bytes per simulated s | "
           "speed-up over jobs 1 |", "|---|---|---|---|---|---|"]
    for r in section["results"]:
        m = r.get("metrics", {})
        out.append("| {} | {} ({}–{}) | {} | {} | {} | {} |".format(
            r["name"], noisy_cell(r, g(r["median_s"])), g(r["min_s"]), g(r["max_s"]),
            g(m.get("x_real_time")), g(m.get("peak_rss_bytes", 0) / 1e6),
            g(m.get("db_bytes_per_simulated_s")), g(m.get("speedup_over_jobs1"))))
    return "\n".join(out + ["", NOISE_NOTE])


def stats_summary(section):
    out = ["| case | median s | median CPU s | cold s | cold CPU s | goal s | cold run meets goal |",
           "|---|---|---|---|---|---|---|"]
    for r in section["results"]:
        out.append("| {} | {} | {} | {} | {} | {} | {} |".format(
            r["what"] or r["name"], noisy_cell(r, g(r["median_s"])), g(r.get("median_cpu_s")),
            g(r.get("cold_s")), g(r.get("cold_cpu_s")) if "cold_cpu_s" in r else "",
            g(r.get("goal_s")) if r.get("goal_s") else "",
            ("yes" if r.get("meets_goal") else "**no**") if r.get("goal_s") else ""))
    return "\n".join(out + ["", NOISE_NOTE])


SUMMARIES = {"search": search_summary, "haptic_scope": haptic_scope_summary,
             "refinement": refinement_summary, "integrators": integrators_summary,
             "sleeping": sleeping_summary, "throughput": throughput_summary,
             "stats": stats_summary}


RATIO_MODELS = ["A", "B", "C", "C_full", "D_condensed", "D_corot", "D_multirate"]


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
             "| region | " + " | ".join(RATIO_MODELS) + " |",
             "|---|" + "---|" * len(RATIO_MODELS)]
    for region in dict.fromkeys(x[0] for x in models):
        t = {model: r["median_s"] for reg, model, r, m in models if reg == region}
        d = t.get("D")
        if not d:
            continue
        ratio.append(f"| {region} | " + " | ".join(
            g(t[k] / d) if t.get(k) else "" for k in
            RATIO_MODELS) + " |")
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
    ap.add_argument("--run-info", action="append", default=[],
                    help="text file: date, commit, command, uptime before/after (repeat it for "
                         "runs split over several processes: one block each)")
    a = ap.parse_args()
    sections = {}
    for f in a.json:
        with open(f) as fh:
            sections.update(json.load(fh))
    with open(a.doc) as fh:
        doc = fh.read()
    blocks = {}
    if a.run_info:
        texts = []
        for f in a.run_info:
            with open(f) as fh:
                texts.append(fh.read().strip())
        blocks["run"] = "```\n" + "\n\n".join(texts) + "\n```"
    for name, sec in sections.items():
        quick = " (`--quick`)" if sec.get("quick") else ""
        body = frontier_tables(sec) if name == "frontier" else generic_table(sec)
        blocks[name] = f"Generated from bench.json{quick} by bench/performance_doc.py:\n\n{body}"
        if name in SUMMARIES:
            blocks[name + "_summary"] = (f"Generated from bench.json{quick} by "
                                         f"bench/performance_doc.py:\n\n{SUMMARIES[name](sec)}")
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
