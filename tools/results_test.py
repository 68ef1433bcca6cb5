"""tools/results.py on real reports: the quickstart release, its `drape eval` report, a
`drape unfold` run and a `drape fold` run, as tests/results_table.sh makes them (CTest
e2e.results_table). Each figure in the table is checked against the report it comes from."""

import json
import os
import shutil
import subprocess
import sys

import pytest

SRC = os.environ.get("SRC", os.path.join(os.path.dirname(__file__), ".."))
TOOL = os.path.join(SRC, "tools", "results.py")
DIRS = {k: os.environ.get("RESULTS_" + k.upper()) for k in ("release", "eval", "unfold", "fold")}
HAVE_REPORTS = all(d and os.path.isdir(d) for d in DIRS.values())
needs_reports = pytest.mark.skipif(not HAVE_REPORTS, reason="run by tests/results_table.sh (CTest e2e.results_table)")


def run(*args):
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True)


def load(path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def rows_of(text):
    """{measure: (drape, paper)} of the markdown table in `text`."""
    rows = {}
    for line in text.splitlines():
        if not line.startswith("| ") or line.startswith("| measure") or line.startswith("|---"):
            continue
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        assert len(cells) == 3, line
        rows[cells[0]] = (cells[1], cells[2])
    return rows


def pct(x):
    return "–" if x is None else f"{100 * x:.1f} %"


def pick(rates):
    return rates["learned"] if rates.get("learned") is not None else rates["unweighted"]


@pytest.fixture(scope="module")
def table():
    out = run(DIRS["release"], DIRS["eval"], DIRS["unfold"], DIRS["fold"])
    assert out.returncode == 0, out.stderr
    return out.stdout


@needs_reports
def test_pose_and_category_rows_are_the_eval_reports(table):
    rows = rows_of(table)
    ev = load(os.path.join(DIRS["eval"], "report.json"))
    for cat in ev["categories"] + [ev["overall"]]:
        name = cat["category"]
        key = f"pose accuracy, {name}: strict [95 % interval] / twin credited ({cat['queries']} test queries)"
        assert key in rows, (key, list(rows))
        strict = pick(cat["pose_accuracy"]["both"])
        twin = pick(cat["pose_accuracy_twin_credited"])
        p = cat["precision"]["strict"]
        assert p["correct"] == round(strict * p["n"])
        interval = f"[{100 * p['low']:.0f}–{100 * p['high']:.0f} %]"
        assert rows[key][0] == f"{pct(strict)} {interval} / {pct(twin)}"
    fit_all = [c for c in ev["category_fit"]["categories"] if c["category"] == "all"][0]
    assert rows["category accuracy: by registration (nearest neighbour)"][0] == (
        f"{pct(fit_all['category_accuracy']['registration'])} ({pct(ev['overall']['category_accuracy'])})")


@needs_reports
def test_registration_and_query_time_rows_are_the_eval_reports(table):
    rows = rows_of(table)
    ev = load(os.path.join(DIRS["eval"], "report.json"))
    avg, paper = ev["registration"]["average"], ev["registration"]["paper"]["average"]
    key = f"registration error S→T, R / R+N (m; {avg['pairs']} test pairs)"
    assert rows[key] == (f"{avg['s_to_t_rigid']:.4f} / {avg['s_to_t_nonrigid']:.4f}", "0.0185 / 0.0070")
    total = ev["overall"]["seconds_per_query"]["total"]
    assert rows["query time: fusion + feature + matching (the build's own timing)"] == (f"{total:.2f} s",
                                                                                      "0.20–0.30 s")


@needs_reports
def test_unfolding_folding_and_build_rows_are_their_reports(table):
    rows = rows_of(table)
    un = load(os.path.join(DIRS["unfold"], "report.json"))
    for r in un["rows"]:
        key = f"unfolding, {r['category']}: recognised / regrasped / unfolded, regrasps on success"
        assert rows[key][0].startswith(f"{r['successful_recognition']} / {r['successful_regrasping']} / "
                                       f"{r['successful_unfolding']} of {r['trials']}, ")
        assert rows[key][0].endswith(f"; {r['declared_not_unfolded']} declared unfolded but not")
        assert rows[key][1].endswith("(average)")  # the paper has no towel row: its average
    fold = load(os.path.join(DIRS["fold"], "trajectories.json"))
    success = sum(t["success"] for t in fold["trials"])
    assert rows[f"folding, {fold['category']}: success over perturbed trials"][0].startswith(
        f"{success}/{len(fold['trials'])}, {len(fold['steps'])} folds")
    build = load(os.path.join(DIRS["release"], "build.json"))
    dataset = load(os.path.join(DIRS["release"], "dataset.json"))
    key = (f"build of the {dataset['name']} {dataset['version']} recipe "
           f"({dataset['counts']['entries']} entries, {dataset['counts']['failed']} failed)")
    assert rows[key][0].startswith(f"{build['wall_seconds']:,.0f} s wall on {build['threads']} threads")
    if "cpu_seconds" in build:
        assert f"{build['cpu_seconds']:,.0f} CPU-s" in rows[key][0]


@needs_reports
def test_stamp_names_the_code_and_machine_of_the_reports(table):
    ev = load(os.path.join(DIRS["eval"], "report.json"))
    p = ev["provenance"]
    stamp = table.strip().splitlines()[-1]
    assert stamp.startswith("Generated by `tools/results.py`")
    assert f"code `{p['code_version']}` on {p['cpu']}, {p['cores']} cores" in stamp
    assert ev["digest"][:12] in stamp


@needs_reports
def test_readme_table_is_replaced_between_the_markers_only(tmp_path, table):
    readme = tmp_path / "README.md"
    before, after = "# title\n\nintro\n\n", "\n\n## next\n\ntext\n"
    readme.write_text(before + "<!-- results:begin -->\nold table\n<!-- results:end -->" + after)
    dirs = [DIRS["release"], DIRS["eval"], DIRS["unfold"], DIRS["fold"]]
    out = run(*dirs, "--readme", str(readme))
    assert out.returncode == 0, out.stderr
    text = readme.read_text()
    assert text == before + "<!-- results:begin -->\n" + table + "<!-- results:end -->" + after
    assert run(*dirs, "--readme", str(readme)).returncode == 0
    assert readme.read_text() == text  # a second run changes nothing


@needs_reports
def test_bad_input_is_a_clear_error(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text("no markers here\n")
    out = run(DIRS["eval"], "--readme", str(readme))
    assert out.returncode == 1 and "<!-- results:begin -->" in out.stderr and str(readme) in out.stderr
    assert readme.read_text() == "no markers here\n"

    out = run(str(tmp_path / "nowhere"))
    assert out.returncode == 1 and "nowhere: no such directory" in out.stderr

    broken = tmp_path / "eval"
    shutil.copytree(DIRS["eval"], broken)
    doc = load(broken / "report.json")
    del doc["overall"]
    (broken / "report.json").write_text(json.dumps(doc))
    out = run(str(broken))
    assert out.returncode == 1 and f'{broken / "report.json"}: no ["overall"]' in out.stderr

    out = run(DIRS["eval"], str(broken))
    assert out.returncode == 1 and "more than one eval report" in out.stderr


def test_missing_values_print_as_a_dash(tmp_path):
    """Hand-made: a category without weights or paper row, and no fold or unfold run."""
    d = tmp_path / "eval"
    d.mkdir()
    cat = {"category": "towel", "queries": 4, "pose_accuracy": {"both": {"unweighted": 0.5, "learned": None}},
           "pose_accuracy_twin_credited": {"unweighted": 0.75, "learned": None}, "category_accuracy": 1.0,
           "seconds_per_query": {"total": None}, "paper": None}
    (d / "report.json").write_text(json.dumps({"categories": [cat], "overall": dict(cat, category="all")}))
    out = run(str(d))
    assert out.returncode == 0, out.stderr
    rows = rows_of(out.stdout)
    assert rows["pose accuracy, towel: strict / twin credited (4 test queries)"] == ("50.0 % / 75.0 %", "–")
    assert rows["category accuracy: nearest neighbour"] == ("100.0 %", "–")
    assert rows["query time: fusion + feature + matching (the build's own timing)"][0] == "–"
    assert "eval: code `unknown code` on an unrecorded machine" in out.stdout



def test_miss_curve_rows_follow_the_pose_rows(tmp_path):
    """Hand-made: an eval report with a miss curve gives the protocol and one row per level."""
    d = tmp_path / "eval"
    d.mkdir()
    cat = {"category": "towel", "queries": 4, "pose_accuracy": {"both": {"unweighted": 0.5, "learned": None}},
           "pose_accuracy_twin_credited": {"unweighted": 0.75, "learned": None}, "category_accuracy": 1.0,
           "seconds_per_query": {"total": None}, "paper": None}

    def figures(strict, twin):
        return {"queries": 4, "strict": {"unweighted": 0.25, "learned": strict},
                "twin_credited": {"unweighted": 0.5, "learned": twin}, "category_accuracy": 1.0}

    level = {"split": "test_miss_10mm", "miss_mm": 10, "differs": "grasp 10 mm from the anchor",
             "categories": {"towel": figures(0.75, 1.0), "all": figures(0.75, 1.0)}}
    curve = {"headline": {"split": "test", "miss_mm": None, "differs": "grasp miss σ 10 mm per axis",
                          "categories": {}}, "levels": [level]}
    (d / "report.json").write_text(json.dumps({"categories": [cat], "overall": dict(cat, category="all"),
                                               "miss_curve": curve}))
    out = run(str(d))
    assert out.returncode == 0, out.stderr
    rows = rows_of(out.stdout)
    assert rows["test protocol of the pose rows above"][0] == "grasp miss σ 10 mm per axis"
    key = "miss curve, grasp 10 mm from the anchor: strict / twin credited, all (4 queries; strict per category)"
    assert rows[key] == ("75.0 % / 100.0 % (towel 75.0 %)", "–")
    del level["categories"]["all"]
    (d / "report.json").write_text(json.dumps({"categories": [cat], "overall": dict(cat, category="all"),
                                               "miss_curve": curve}))
    out = run(str(d))
    assert out.returncode == 1 and '["all"]' in out.stderr
