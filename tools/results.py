#!/usr/bin/env python3
"""The README's results table, from the reports drape's commands write.

    tools/results.py REPORT_DIR... [--readme README.md]

Each REPORT_DIR is recognised by what it holds:
  a release       dataset.json + build.json          (`drape build`: the build's time)
  an eval report  report.json with "categories"      (`drape eval -o DIR`; with its miss curve
                                                     when the release's recipe has one)
  an unfold run   report.json with "rows"            (`drape unfold -o DIR`)
  a fold run      trajectories.json with "trials"    (`drape fold -o DIR`; one per garment)

The table puts drape's figures beside the paper's and is stamped with the code version and
the machine (CPU model, cores) each report records (its "provenance"). With --readme the
table replaces what lies between the lines `<!-- results:begin -->` and
`<!-- results:end -->` of that file; without it the table is printed. Only the standard
library is used. tools/results.sh runs the whole chain on the paper recipe and then this.
"""

import argparse
import json
import os
import sys

BEGIN = "<!-- results:begin -->"
END = "<!-- results:end -->"

# The paper's folding figure (Table "garment_stat_fold": the average over its garments);
# no drape report carries it. Every other paper figure comes from the reports themselves.
PAPER_FOLD = "9.3/10 (average of its garments), 2.3 folds"
# The paper's recognition time per garment (§"Pose Estimation"; i7 3.0 GHz, KinectFusion).
PAPER_QUERY_SECONDS = "0.20–0.30 s"

CATEGORY_NAMES = {"long_sleeve_shirt": "long-sleeve shirt", "tshirt": "T-shirt"}


class ReportError(Exception):
    """A report that is missing or lacks a field the table needs: says which file and what."""


def load_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise ReportError(f"{path}: cannot read ({e.strerror})") from None
    except json.JSONDecodeError as e:
        raise ReportError(f"{path}:{e.lineno}:{e.colno}: not JSON ({e.msg})") from None


def field(doc, path, keys):
    """doc[k0][k1]...; a clear error naming the file and the key path when one is absent."""
    cur = doc
    for i, k in enumerate(keys):
        if isinstance(cur, dict) and k in cur:
            cur = cur[k]
        elif isinstance(cur, list) and isinstance(k, int) and -len(cur) <= k < len(cur):
            cur = cur[k]
        else:
            where = "".join(f"[{json.dumps(x)}]" for x in keys[: i + 1])
            raise ReportError(f"{path}: no {where}")
    return cur


def classify(directory):
    """(kind, document, file) for one report directory."""
    d = directory
    if os.path.isfile(os.path.join(d, "dataset.json")) and os.path.isfile(os.path.join(d, "build.json")):
        return "build", {"dataset": load_json(os.path.join(d, "dataset.json")),
                         "build": load_json(os.path.join(d, "build.json"))}, os.path.join(d, "build.json")
    report = os.path.join(d, "report.json")
    if os.path.isfile(report):
        doc = load_json(report)
        if isinstance(doc, dict) and "categories" in doc:
            return "eval", doc, report
        if isinstance(doc, dict) and "rows" in doc:
            return "unfold", doc, report
        raise ReportError(f"{report}: neither a drape eval report (no \"categories\") "
                          f"nor a drape unfold report (no \"rows\")")
    traj = os.path.join(d, "trajectories.json")
    if os.path.isfile(traj):
        doc = load_json(traj)
        if isinstance(doc, dict) and "trials" in doc:
            return "fold", doc, traj
        raise ReportError(f"{traj}: no \"trials\" (a drape fold run stopped before its trials, "
                          f"or --trials 0)")
    if not os.path.isdir(d):
        raise ReportError(f"{d}: no such directory")
    raise ReportError(f"{d}: not a release (dataset.json + build.json), an eval report or an unfold "
                      f"run (report.json), nor a fold run (trajectories.json)")


def pct(x):
    return "–" if x is None else f"{100 * x:.1f} %"


def metres(x):
    return "–" if x is None else f"{x:.4f}"


def category_name(c):
    return CATEGORY_NAMES.get(c, c)


def learned_or_unweighted(rates):
    """The learned figure when the release has weights for it, else the unweighted one."""
    if rates.get("learned") is not None:
        return rates["learned"]
    return rates.get("unweighted")


def strict_interval(cat):
    """The " [12–49 %]" after strict pose: its 95 % Wilson interval from the eval's
    "precision" ("" for reports from before it)."""
    p = (cat.get("precision") or {}).get("strict")
    return "" if not p else f" [{100 * p['low']:.0f}–{100 * p['high']:.0f} %]"


def eval_rows(doc, path):
    rows = []
    for cat in field(doc, path, ["categories"]) + [field(doc, path, ["overall"])]:
        name = field(cat, path, ["category"])
        strict = learned_or_unweighted(field(cat, path, ["pose_accuracy", "both"]))
        twin = learned_or_unweighted(field(cat, path, ["pose_accuracy_twin_credited"]))
        paper = cat.get("paper") or {}
        label = "all" if name == "all" else category_name(name)
        interval = strict_interval(cat)
        what = "strict [95 % interval] / twin credited" if interval else "strict / twin credited"
        rows.append((f"pose accuracy, {label}: {what} ({field(cat, path, ['queries'])} test queries)",
                     f"{pct(strict)}{interval} / {pct(twin)}", pct(paper.get("both"))))
    rows += miss_curve_rows(doc, path)
    rows += k_curve_rows(doc, path)
    overall = field(doc, path, ["overall"])
    nn = field(overall, path, ["category_accuracy"])
    fit = doc.get("category_fit")
    if fit:
        fit_all = [c for c in field(fit, path, ["categories"]) if c.get("category") == "all"]
        if not fit_all:
            raise ReportError(f"{path}: no \"all\" row in [\"category_fit\"][\"categories\"]")
        by_fit = field(fit_all[0], path, ["category_accuracy", "registration"])
        rows.append(("category accuracy: by registration (nearest neighbour)", f"{pct(by_fit)} ({pct(nn)})", "–"))
    else:
        rows.append(("category accuracy: nearest neighbour", pct(nn), "–"))
    reg = doc.get("registration")
    if reg:
        avg = field(reg, path, ["average"])
        paper = (reg.get("paper") or {}).get("average") or {}
        rows.append((f"registration error S→T, R / R+N (m; {field(avg, path, ['pairs'])} test pairs)",
                     f"{metres(avg.get('s_to_t_rigid'))} / {metres(avg.get('s_to_t_nonrigid'))}",
                     f"{metres(paper.get('s_to_t_rigid'))} / {metres(paper.get('s_to_t_nonrigid'))}"))
    seconds = field(overall, path, ["seconds_per_query"])
    total = seconds.get("total")
    rows.append(("query time: fusion + feature + matching (the build's own timing)",
                 "–" if total is None else f"{total:.2f} s", PAPER_QUERY_SECONDS))
    return rows


def curve_cells(level, path):
    """A miss or K curve level's "all" figures and its cell: all categories strict / twin
    credited, then each category strict."""
    cats = field(level, path, ["categories"])
    every = field(cats, path, ["all"])
    strict = learned_or_unweighted(field(every, path, ["strict"]))
    twin = learned_or_unweighted(field(every, path, ["twin_credited"]))
    per = ", ".join(f"{category_name(c)} {pct(learned_or_unweighted(field(f, path, ['strict'])))}"
                    for c, f in cats.items() if c != "all")
    return every, f"{pct(strict)} / {pct(twin)} ({per})"


def miss_curve_rows(doc, path):
    """The protocol the pose rows were measured at, and the eval's miss curve (when its
    release's recipe has one): all categories strict / twin credited, each category strict."""
    curve = doc.get("miss_curve")
    if not curve:
        return []
    rows = []
    head = curve.get("headline")
    if head:
        rows.append(("test protocol of the pose rows above", field(head, path, ["differs"]),
                     "real garments, grasped at the anchors (no miss stated)"))
    for level in field(curve, path, ["levels"]):
        every, cells = curve_cells(level, path)
        rows.append((f"miss curve, grasp {field(level, path, ['miss_mm'])} mm from the anchor: strict / twin "
                     f"credited, all ({field(every, path, ['queries'])} queries; strict per category)",
                     cells, "–"))
    return rows


def k_curve_rows(doc, path):
    """The eval's K curve (releases with hangs_per_anchor K > 1): all categories strict / twin
    credited at each K' hangs per anchor in the database, each category strict."""
    curve = doc.get("k_curve")
    if not curve:
        return []
    rows = []
    for level in field(curve, path, ["levels"]):
        every, cells = curve_cells(level, path)
        k = field(level, path, ["hangs"])
        rows.append((f"K curve, {k} hang{'' if k == 1 else 's'} per anchor "
                     f"({field(level, path, ['database_entries'])} database entries): strict / twin credited, all "
                     f"({field(every, path, ['queries'])} queries; strict per category)",
                     cells, "–"))
    return rows


def unfold_rows(doc, path):
    paper = field(doc, path, ["paper"])
    paper_by_name = {r.get("garment", "").lower(): r for r in paper.get("rows", [])}
    average = paper.get("average", {})
    rows = []
    for r in field(doc, path, ["rows"]):
        if r.get("variant", "full") != "full":
            continue
        cat = field(r, path, ["category"])
        n = field(r, path, ["trials"])
        regrasps = r.get("avg_regrasps_success_only")
        mine = (f"{r['successful_recognition']} / {r['successful_regrasping']} / "
                f"{field(r, path, ['successful_unfolding'])} of {n}, "
                + ("–" if regrasps is None else f"{regrasps:.1f}"))
        if r.get("declared_not_unfolded") is not None:  # reports from 2026-12-06 on
            mine += f"; {r['declared_not_unfolded']} declared unfolded but not"
        p = paper_by_name.get(cat.lower())
        if p:
            theirs = (f"{p['successful_recognition']} / {p['successful_regrasping']} / "
                      f"{p['successful_unfolding']} of {p['trials']}, {p['avg_regrasps_success_only']:.1f}")
        else:
            theirs = (f"{average.get('successful_recognition')} / {average.get('successful_regrasping')} / "
                      f"{average.get('successful_unfolding')} of 10, {average.get('avg_regrasps_success_only')} "
                      f"(average)")
        rows.append((f"unfolding, {category_name(cat)}: recognised / regrasped / unfolded, regrasps on success",
                     mine, theirs))
    if not rows:
        raise ReportError(f"{path}: no row of the variant \"full\" in [\"rows\"]")
    return rows


def fold_rows(docs):
    rows = []
    for doc, path in docs:
        trials = field(doc, path, ["trials"])
        success = sum(1 for t in trials if t.get("success"))
        garment = field(doc, path, ["category"])
        folds = len(field(doc, path, ["steps"]))
        mine = f"{success}/{len(trials)}, {folds} folds ({doc.get('vertices', '?')} nodes)"
        rows.append((f"folding, {category_name(garment)}: success over perturbed trials", mine, PAPER_FOLD))
    return rows


def build_rows(doc, path):
    dataset, build = doc["dataset"], doc["build"]
    name = f"{dataset.get('name', '?')} {dataset.get('version', '')}".strip()
    counts = dataset.get("counts") or {}
    entries = counts.get("entries", counts.get("total"))
    failed = counts.get("failed")
    wall = field(build, path, ["wall_seconds"])
    threads = build.get("threads")
    cpu = build.get("cpu_seconds")
    what = f"{wall:,.0f} s wall on {threads} threads" if threads else f"{wall:,.0f} s wall"
    if cpu is not None:
        what += f", {cpu:,.0f} CPU-s"
    label = f"build of the {name} recipe"
    if entries is not None:
        label += f" ({entries} entries" + (f", {failed} failed)" if failed is not None else ")")
    return [(label, what, "–")]


def provenance_of(kind, doc):
    if kind == "build":
        p = doc["build"].get("provenance")
        if p:
            return p
        version = doc["build"].get("code_version")
        return {"code_version": version} if version else None
    return doc.get("provenance")


def stamp(reports):
    """One line naming the code and machine of every report (grouped when they agree)."""
    groups = {}
    for kind, doc, _ in reports:
        p = provenance_of(kind, doc) or {}
        key = (p.get("code_version", "unknown code"), p.get("cpu", "an unrecorded machine"), p.get("cores"))
        groups.setdefault(key, []).append(kind)
    parts = []
    for (code, cpu, cores), kinds in groups.items():
        machine = cpu if cores is None else f"{cpu}, {cores} cores"
        parts.append(f"{', '.join(kinds)}: code `{code}` on {machine}")
    return "Generated by `tools/results.py` from the reports of " + "; ".join(parts) + "." + releases(reports)


def release_of(kind, doc):
    """(name, digest) of the release a report was made on, or None when it does not say."""
    if kind == "build":
        d = doc["dataset"]
        name, digest = f"{d.get('name', '')} {d.get('version', '')}".strip(), d.get("digest")
    elif kind in ("eval", "unfold"):
        name, digest = f"{doc.get('name', '')} {doc.get('version', '')}".strip(), doc.get("digest")
        if not name and doc.get("release"):
            try:
                d = load_json(os.path.join(doc["release"], "dataset.json"))
                name = f"{d.get('name', '')} {d.get('version', '')}".strip()
            except ReportError:
                pass
    else:
        return None
    return (name or "an unnamed release", digest) if digest else None


def releases(reports):
    """The release under the eval report, or, when reports come from different releases (a
    table put together from two runs), each report's own, so no row is credited to the
    wrong release."""
    seen = {}
    for kind, doc, _ in reports:
        r = release_of(kind, doc)
        if r:
            seen.setdefault(r, []).append(kind)
    if not seen:
        return ""
    if len(seen) == 1:
        (name, digest), = seen
        return f" Release `{name}`, digest `{digest[:12]}…`."
    return " Releases: " + "; ".join(f"{', '.join(kinds)} on `{name}` (digest `{digest[:12]}…`)"
                                     for (name, digest), kinds in seen.items()) + "."


def table(dirs):
    reports = [classify(d) for d in dirs]
    kinds = [k for k, _, _ in reports]
    for k in ("build", "eval", "unfold"):
        if kinds.count(k) > 1:
            names = [p for kk, _, p in reports if kk == k]
            raise ReportError(f"more than one {k} report given: {', '.join(names)}")
    rows = []
    for kind in ("eval", "unfold", "build"):
        for k, doc, path in reports:
            if k == kind:
                rows += {"eval": eval_rows, "unfold": unfold_rows, "build": build_rows}[kind](doc, path)
    folds = [(doc, path) for k, doc, path in reports if k == "fold"]
    if folds:
        # folding after unfolding, before the build line
        at = next((i for i, r in enumerate(rows) if r[0].startswith("build of")), len(rows))
        rows[at:at] = fold_rows(folds)
    lines = ["| measure | drape | paper |", "|---|---|---|"]
    lines += [f"| {a} | {b} | {c} |" for a, b, c in rows]
    return "\n".join(lines) + "\n\n" + stamp(reports) + "\n"


def replace_between_markers(text, body, path):
    b, e = text.find(BEGIN), text.find(END)
    if b < 0 or e < 0 or e < b:
        raise ReportError(f"{path}: needs the lines {BEGIN} and {END} (in that order) around the table")
    return text[: b + len(BEGIN)] + "\n" + body + text[e:]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog=__doc__.split("\n\n", 2)[2])
    ap.add_argument("reports", nargs="+", metavar="REPORT_DIR")
    ap.add_argument("--readme", metavar="FILE", help="rewrite the table between the markers of FILE")
    args = ap.parse_args(argv)
    try:
        body = table(args.reports)
        if args.readme:
            with open(args.readme, encoding="utf-8") as f:
                text = f.read()
            new = replace_between_markers(text, body, args.readme)
            if new != text:
                tmp = args.readme + ".tmp"
                with open(tmp, "w", encoding="utf-8") as f:
                    f.write(new)
                os.replace(tmp, args.readme)
            print(f"{args.readme}: results table written")
        else:
            sys.stdout.write(body)
    except ReportError as e:
        print(f"results.py: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"results.py: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
