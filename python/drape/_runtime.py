"""The runtime's release-free functions: registration, feature matching and extraction."""

from __future__ import annotations

import contextlib
import json
import os
import tempfile
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

from . import _drape
from ._drape import DrapeError


def _as_vf(mesh, what: str):
    """(V, F) from a (V, F) pair, an object with .V/.F, or an Open3D TriangleMesh."""
    if hasattr(mesh, "vertices") and hasattr(mesh, "triangles"):  # open3d.geometry.TriangleMesh
        return np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.triangles, dtype=np.int64)
    try:
        V, F = mesh
    except (TypeError, ValueError):
        raise DrapeError(f"{what}: expected a file path, (V, F) arrays or an Open3D TriangleMesh") from None
    return np.asarray(V, dtype=np.float64), np.asarray(F, dtype=np.int64)


@contextlib.contextmanager
def _temp_ply(mesh):
    """The mesh written to a temporary binary PLY by drape's own encoder."""
    V, F = _as_vf(mesh, "mesh")
    fd, path = tempfile.mkstemp(suffix=".ply", prefix="drape_")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(_drape.encode_ply(V, F))
        yield path
    finally:
        os.unlink(path)


@dataclass
class Registration:
    """Result of drape.register (the same numbers `drape register --json` prints)."""

    rigid: Tuple[np.ndarray, np.ndarray]     # source after scaling + ICP (R): (V, F)
    nonrigid: Tuple[np.ndarray, np.ndarray]  # after R+N (== rigid with rigid_only=True)
    s_to_t: float                            # area-weighted mean distance, metres (last step)
    t_to_s: float
    anchors: List[Dict[str, Any]]            # transferred anchors
    report: Dict[str, Any] = field(repr=False)


def register(source, target, rigid_only: bool = False, *, anchors=None, scale: bool = True,
             grid_cells: Optional[int] = None, kappa: Optional[float] = None, beta: Optional[float] = None,
             alpha: Optional[float] = None, iterations: Optional[int] = None) -> Registration:
    """Registers `source` onto `target` (scale, ICP on a closest-point grid, non-rigid
    secant Levenberg-Marquardt), as `drape register SOURCE TARGET`.

    source, target: a mesh file path, (V, F) arrays, or an Open3D TriangleMesh. A source
    path with a NAME.anchors.json sidecar brings its anchors (as the CLI); or pass
    anchors=[(label, vertex), ...].
    """
    anchor_list: List[Tuple[str, int]] = [(str(l), int(v)) for l, v in (anchors or [])]
    if isinstance(source, (str, os.PathLike)):
        src = os.fspath(source)
        sidecar = os.path.splitext(src)[0] + ".anchors.json"
        if anchors is None and os.path.isfile(sidecar):
            V, F, anchor_list = _drape.import_with_anchors(src, sidecar)
            sv, sf = V, F
        else:
            sv, sf = _drape.read_mesh(src)
    else:
        sv, sf = _as_vf(source, "source")
    tv, tf = _drape.read_mesh(os.fspath(target)) if isinstance(target, (str, os.PathLike)) else _as_vf(target, "target")
    out = _drape.register(sv, sf, tv, tf, anchor_list, rigid_only, scale, grid_cells, kappa, beta, alpha, iterations)
    rep = json.loads(out["report_json"])
    step = "rigid" if rigid_only else "nonrigid"
    return Registration(rigid=out["rigid"], nonrigid=out["nonrigid"], s_to_t=rep[f"s_to_t_{step}"]["mean"],
                        t_to_s=rep[f"t_to_s_{step}"]["mean"], anchors=rep["anchors"], report=rep)


def match(f1, f2) -> Tuple[int, int]:
    """Rotation-invariant Hamming distance of two features (paper Eq. match):
    (distance in bits, rotation k) with f2 ~ f1 turned by k sectors."""
    return _drape.match(np.asarray(f1, dtype=bool), np.asarray(f2, dtype=bool))


def extract_feature(points=None, sdf=None, *, entry=None, release=None, sweep=None, mesh=None,
                    layers: int = 16, rings: int = 16, sectors: int = 16, origin: str = "top_layer",
                    seed: int = 0) -> np.ndarray:
    """The paper's binary cylindrical feature (Algorithm 1, C++), from
      entry=Entry                 its recon.ply vertices and sdf.vdb, with the release's
                                  feature shape (what the build stored, up to float rounding)
      points=(P, 3), sdf=PATH     surface points and a .vdb file's "sdf" grid (origin: the
                                  polar axis, "top_layer" as Algorithm 1 or "grip")
      release=R, sweep=DIR        a recorded sweep, fused with R's recipe options
      release=R, mesh=...         a hung mesh: synthetic sweep + fusion with R's options
    Returns numpy bool (layers, rings, sectors)."""
    if release is not None:
        return release.extract_feature(sweep=sweep, mesh=mesh, seed=seed)
    if entry is not None:
        shape = entry.record.get("feature", {})
        V, _ = entry.recon_mesh()
        return _drape.extract_feature_vdb(V, entry.path("sdf.vdb"), int(shape.get("layers", layers)),
                                          int(shape.get("rings", rings)), int(shape.get("sectors", sectors)),
                                          str(shape.get("origin", origin)))
    if points is None or sdf is None:
        raise DrapeError("extract_feature: give entry=, points= and sdf=, or release= with sweep= or mesh=")
    return _drape.extract_feature_vdb(np.asarray(points, dtype=np.float64), os.fspath(sdf), layers, rings, sectors,
                                      origin)
