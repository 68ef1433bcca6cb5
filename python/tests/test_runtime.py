"""Recognition, registration and matching from Python equal the drape CLI's results."""

import json

import numpy as np
import pytest

import drape
from conftest import run_drape


def without_timing(j):
    return {k: v for k, v in j.items() if k not in ("match_seconds", "timing")}


def test_recognize_entry_equals_cli(release, release_dir):
    for e in release.entries(split="test"):
        r = release.recognize(entry=e.id)
        cli = json.loads(run_drape("recognize", release_dir, "--entry", e.id, "--json"))
        assert without_timing(r.result) == without_timing(cli["result"])
        assert r.anchor_position == cli["anchor_position"]
        assert (r.category, r.anchor, r.entry) == (cli["result"]["category"], cli["result"]["anchor"],
                                                   cli["result"]["best"]["entry"])
        assert r.category == "towel" and r.query["true_anchor"] == e.anchor


def test_recognize_sweep_equals_cli(release, release_dir):
    e = release.entries(split="test")[0]
    r = release.recognize(sweep=e.path("sweep"), top_k=3)
    cli = json.loads(run_drape("recognize", release_dir, "--sweep", e.path("sweep"), "--top-k", "3", "--json"))
    assert without_timing(r.result) == without_timing(cli["result"])
    assert len(r.top) <= 3


def test_recognize_mesh_equals_cli_and_accepts_arrays(release, release_dir):
    e = release.entries(split="test")[1]
    path = e.path("hang.ply")
    r = release.recognize(mesh=path, seed=3)
    cli = json.loads(run_drape("recognize", release_dir, "--mesh", path, "--seed", "3", "--json"))
    assert without_timing(r.result) == without_timing(cli["result"])
    # The same mesh as arrays: written by drape's PLY encoder, read back by assimp.
    assert without_timing(release.recognize(mesh=e.hang_mesh(), seed=3).result) == without_timing(r.result)


def test_recognize_feature_and_bad_queries(release):
    e = release.entries(split="train")[0]
    r = release.recognize(feature=e.feature())
    assert r.entry == e.id and r.distance == 0  # a database entry finds itself
    with pytest.raises(drape.DrapeError, match="exactly one"):
        release.recognize(entry=e.id, feature=e.feature())
    with pytest.raises(drape.DrapeError, match="no entry 'nope'"):
        release.recognize(entry="nope")
    with pytest.raises(drape.DrapeError):
        release.recognize(feature=np.zeros((4, 4, 4), dtype=bool))  # another shape


def test_register_equals_cli(release, release_dir, tmp_path):
    src = release.entries(split="train")[0].path("hang.ply")
    dst = release.entries(split="test")[0].path("recon.ply")
    config = tmp_path / "options.yaml"
    config.write_text("registration:\n  iterations: 10\n")  # the CLI's research knobs live in --config
    for rigid_only in (True, False):
        reg = drape.register(src, dst, rigid_only=rigid_only, iterations=10)
        args = ["register", src, dst, "--json", "--config", config, "-o", tmp_path / "out.ply"]
        cli = json.loads(run_drape(*args, *(["--rigid-only"] if rigid_only else [])))
        step = "rigid" if rigid_only else "nonrigid"
        for k in (f"s_to_t_{step}", f"t_to_s_{step}"):
            assert reg.report[k] == cli[k]
        assert reg.s_to_t == cli[f"s_to_t_{step}"]["mean"]
        V, F = reg.nonrigid
        W, G = drape._drape.read_mesh(str(tmp_path / "out.ply"))
        np.testing.assert_array_equal(F, G)
        np.testing.assert_allclose(V, W, atol=1e-6)  # the CLI's output PLY stores float32
    # Arrays and Open3D meshes are accepted as well, with explicit anchors.
    e = release.entries(split="train")[0]
    reg2 = drape.register(e.hang_mesh(open3d=True), release.entries(split="test")[0].recon_mesh(),
                          rigid_only=True, anchors=[(e.anchor, e.anchor_vertex)])
    assert reg2.anchors[0]["label"] == e.anchor and reg2.s_to_t < 0.05


def test_match_against_brute_force(release):
    rng = np.random.default_rng(5)
    fs = [e.feature() for e in release.entries()]
    for a in fs:
        for b in fs[:3]:
            d = [(np.count_nonzero(np.roll(a, k, axis=2) ^ b), k) for k in range(a.shape[2])]
            assert drape.match(a, b) == min(d)
    a = rng.random((16, 16, 16)) < 0.3
    assert drape.match(a, np.roll(a, 5, axis=2)) == (0, 5)
    with pytest.raises(drape.DrapeError):
        drape.match(a, a[:8])


def test_extract_feature_of_a_sweep_equals_cli_refuse(release, release_dir):
    # The query pipeline re-fuses a kept sweep; `drape recognize --refuse` reports the
    # distance of that re-extraction to the stored feature.
    e = release.entries(split="test")[0]
    f = drape.extract_feature(release=release, sweep=e.path("sweep"))
    cli = json.loads(run_drape("recognize", release_dir, "--entry", e.id, "--refuse", "--json"))
    d, k = drape.match(e.feature(), f)
    assert {"distance": d, "rotation": k} == cli["query"]["refused_vs_stored_feature"]
