"""drape.open_release and Entry readers: values equal to what the C++ side wrote and
reads (catalog rows, feature bits, vertex counts), and clear errors on bad input."""

import json
import re
import shutil
import sqlite3

import numpy as np
import pytest

import drape
from conftest import run_drape


def parse_feature_bin(data: bytes) -> np.ndarray:
    """feature.bin by hand (generator/feature/feature.h): 'DRFT', u32 version, N, R, Phi,
    W, then W little-endian u64 words, bit i of the feature = bit i % 64 of word i / 64."""
    assert data[:4] == b"DRFT"
    version, n, r, phi, w = np.frombuffer(data[4:24], dtype="<u4")
    assert version == 1 and len(data) == 24 + 8 * int(w)
    bits = np.unpackbits(np.frombuffer(data[24:], dtype=np.uint8), bitorder="little")
    return bits[: n * r * phi].astype(bool).reshape(n, r, phi)


def ply_counts(path) -> tuple:
    header = open(path, "rb").read(4096).split(b"end_header")[0].decode()
    v = int(re.search(r"element vertex (\d+)", header).group(1))
    f = int(re.search(r"element face (\d+)", header).group(1))
    return v, f


def test_metadata_matches_dataset_json(release, release_dir):
    ds = json.loads((release_dir / "dataset.json").read_text())
    assert release.name == ds["name"] == "tiny-sweeps"
    assert release.version == ds["version"]
    assert release.digest == ds["digest"]
    assert release.metadata["counts"] == ds["counts"]
    assert len(release.entries()) == ds["counts"]["entries"] - ds["counts"]["failed"]
    assert release.splits == ["train", "test"]
    assert {s: len(release.entries(split=s, include_failed=True)) for s in release.splits} == ds["counts"]["splits"]


def test_entries_equal_catalog_rows(release, release_dir):
    con = sqlite3.connect(release_dir / "catalog.sqlite")
    rows = con.execute("SELECT id, key, split, failed, category, record_json FROM entries ORDER BY id").fetchall()
    entries = release.entries(include_failed=True)
    assert [(e.id, e.key, e.split, int(e.failed), e.category) for e in entries] == [r[:5] for r in rows]
    assert [e.record for e in entries] == [json.loads(r[5]) for r in rows]
    # The same listing as `drape ls --json` (the C++ reader).
    listed = json.loads(run_drape("ls", release_dir, "--json"))
    assert [(e.id, e.key, e.split, e.failed, e.failure, e.record, e.files) for e in entries] == [
        (j["id"], j["key"], j["split"], j["failed"], j["failure"], j["record"], {f["path"]: f["size"] for f in j["files"]})
        for j in listed]
    assert len(entries) == 6


def test_feature_bits_equal_file_and_catalog_blob(release, release_dir):
    con = sqlite3.connect(release_dir / "catalog.sqlite")
    blobs = dict(con.execute("SELECT id, feature FROM entries"))
    for e in release.entries():
        f = e.feature()
        assert f.dtype == np.bool_ and f.shape == (16, 16, 16)
        by_hand = parse_feature_bin((release_dir / "entries" / e.id / "feature.bin").read_bytes())
        np.testing.assert_array_equal(f, by_hand)
        np.testing.assert_array_equal(f, parse_feature_bin(blobs[e.id]))
        assert 0 < f.sum() < f.size
        assert f.sum() == e.record["feature"]["ones"]


def test_mesh_vertex_counts(release, release_dir):
    for e in release.entries():
        V, F = e.hang_mesh()
        assert V.dtype == np.float64 and V.shape[1] == 3 and F.dtype == np.int32 and F.shape[1] == 3
        assert (V.shape[0], F.shape[0]) == ply_counts(release_dir / "entries" / e.id / "hang.ply")
        assert F.min() >= 0 and F.max() < V.shape[0]
        # Object frame: the grasped anchor at the gripper (origin + grasp offset), the
        # garment hanging below it.
        np.testing.assert_allclose(V[e.anchor_vertex], e.record["grasp_offset"], atol=1e-6)
        assert V[:, 1].min() < -0.2
        R, G = e.recon_mesh()
        assert (R.shape[0], G.shape[0]) == ply_counts(release_dir / "entries" / e.id / "recon.ply")
        assert R.shape[0] == e.record["fusion"]["mesh_vertices"]
        m = e.recon_mesh(open3d=True)
        assert len(m.vertices) == R.shape[0] and len(m.triangles) == G.shape[0]
    e = release.entries()[0]
    assert 0 <= e.anchor_vertex < e.hang_mesh()[0].shape[0]
    # The types a caller keeps, converted in C++ (drape.torch asks for float32 / int64).
    V, F = e.hang_mesh()
    V32, F64 = drape._drape.read_mesh(e.path("hang.ply"), "float32", "int64")
    assert V32.dtype == np.float32 and F64.dtype == np.int64
    np.testing.assert_array_equal(V32, V.astype(np.float32))
    np.testing.assert_array_equal(F64, F)
    with pytest.raises(drape.DrapeError, match="vertex_dtype must be float64 or float32, not 'float16'"):
        drape._drape.read_mesh(e.path("hang.ply"), "float16")


def test_sdf_volume(release):
    e = release.entries(split="test")[0]
    s = e.sdf()
    vol, T, h = s["sdf"], s["index_to_object"], s["voxel_size"]
    assert vol.dtype == np.float32 and vol.ndim == 3 and s["weight"].shape == vol.shape
    assert h == pytest.approx(1 / 96)
    assert np.allclose(T[:3, :3], np.eye(3) * h) and np.allclose(T[:3, 3], np.array(s["origin_index"]) * h)
    assert vol.min() < 0 < vol.max() and np.abs(vol).max() <= s["truncation"] + 1e-6
    # The fused mesh is the zero level set (marching cubes): each vertex lies in a voxel
    # cell whose 8 corner values change sign (outside the array the field is +truncation).
    V, _ = e.recon_mesh()
    vol = np.pad(vol, 1, constant_values=s["truncation"])
    lo = np.floor((V - T[:3, 3]) / h + 1e-9).astype(int) + 1
    assert (lo >= 0).all() and (lo + 1 < vol.shape).all()
    corners = np.stack([vol[lo[:, 0] + a, lo[:, 1] + b, lo[:, 2] + c]
                        for a in (0, 1) for b in (0, 1) for c in (0, 1)], axis=1)
    assert ((corners.min(axis=1) <= 0) & (corners.max(axis=1) >= 0)).all()


def test_feature_from_stored_sdf_equals_stored_feature(release):
    # Algorithm 1 on recon.ply's vertices and sdf.vdb (OpenVDB's trilinear sampler, in
    # float) against the feature the build computed from the in-memory TSDF (double).
    for e in release.entries():
        f = drape.extract_feature(entry=e)
        d, _ = drape.match(f, e.feature())
        assert d <= 2, e.id


def test_feature_origin_on_the_grip(release):
    # The polar axis on the gripper's (x = z = 0) instead of the top layer's mean: a feature
    # of the same shape, the default unchanged, and a bad name refused.
    e = release.entries()[0]
    V, _ = e.recon_mesh()
    top = drape.extract_feature(points=V, sdf=e.path("sdf.vdb"))
    grip = drape.extract_feature(points=V, sdf=e.path("sdf.vdb"), origin="grip")
    assert grip.shape == top.shape and grip.any()
    assert np.array_equal(drape.extract_feature(points=V, sdf=e.path("sdf.vdb"), origin="top_layer"), top)
    with pytest.raises(drape.DrapeError, match="origin"):
        drape.extract_feature(points=V, sdf=e.path("sdf.vdb"), origin="centre")


def test_sweep_and_preview(release, release_dir):
    e = release.entries(split="test")[0]
    s = e.sweep()
    d = s["depth_mm"]
    assert d.dtype == np.uint16 and d.shape == (12, s["intrinsics"]["height"], s["intrinsics"]["width"])
    assert s["camera_to_object"].shape == (12, 4, 4) and s["gripper_angle"].shape == (12,)
    # Frames equal the 16-bit PNGs on disk (read by OpenCV, no conversion).
    pngs = sorted(p for p in (release_dir / "entries" / e.id / "sweep").glob("*.png"))
    assert len(pngs) == 12
    np.testing.assert_array_equal(d[3], drape._drape.read_image(str(pngs[3])))
    assert (d > 0).mean() > 0.1
    p = e.preview()
    assert p.dtype == np.uint8 and p.ndim == 3 and p.shape[2] == 3 and p.std() > 1
    with pytest.raises(drape.DrapeError, match="no sweep/cameras.json"):
        release.entries(split="train")[0].sweep()  # the database keeps no sweep


def test_missing_release_raises():
    with pytest.raises(drape.ReleaseNotFoundError, match="no such release"):
        drape.open_release("/nonexistent/release")
    with pytest.raises(FileNotFoundError):
        drape.open_release("/nonexistent/release")


def test_not_a_release_raises(tmp_path):
    (tmp_path / "dataset.json").write_text("{}")
    with pytest.raises(drape.DrapeError, match="not a finished drape release"):
        drape.open_release(tmp_path)


def test_wrong_split_and_category_name(release):
    with pytest.raises(drape.DrapeError, match=r"no split 'trian' \(this release has: train, test\)"):
        release.entries(split="trian")
    with pytest.raises(drape.DrapeError, match="no category 'shirt'"):
        release.entries(category="shirt")
    with pytest.raises(drape.DrapeError, match="no entry 'nope'"):
        release.entry("nope")


def test_corrupt_entry_files_raise(release_dir, tmp_path):
    copy = tmp_path / "rel"
    shutil.copytree(release_dir, copy)
    r = drape.open_release(copy)
    e = r.entries()[0]
    base = copy / "entries" / e.id
    (base / "feature.bin").write_bytes((base / "feature.bin").read_bytes()[:30])
    with pytest.raises(drape.DrapeError, match="feature.bin"):
        e.feature()
    (base / "hang.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 9\nend_header\n\x00")
    with pytest.raises(drape.DrapeError, match="hang.ply"):
        e.hang_mesh()
    (base / "sdf.vdb").write_bytes(b"garbage")
    with pytest.raises(drape.DrapeError, match="sdf.vdb"):
        e.sdf()
    (base / "preview.png").write_bytes(b"garbage")
    with pytest.raises(drape.DrapeError, match="preview.png"):
        e.preview()
    # A damaged entry.json makes the release itself unreadable, with the file named.
    (base / "entry.json").write_text("{")
    (copy / "catalog.sqlite").unlink()
    with pytest.raises(drape.DrapeError):
        drape.open_release(copy)
