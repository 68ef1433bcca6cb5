"""Releases and their entries (reading through drape's C++ release reader)."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional

from . import _drape
from ._drape import DrapeError


class ReleaseNotFoundError(DrapeError, FileNotFoundError):
    """The path holds no finished release (no such folder, or no dataset.json/SHA256SUMS)."""


def open_release(path: "str | os.PathLike[str]") -> "Release":
    """Opens a finished release folder (what `drape build` writes).

    Raises ReleaseNotFoundError if there is none at `path`, DrapeError if it is damaged.
    """
    return Release(path)


def _ensure(entry: "Entry", name: str) -> str:
    if entry.failed:
        raise DrapeError(f"entry {entry.id} failed in the build ({entry.failure}): it has no {name}")
    if name not in entry.files:
        raise DrapeError(f"entry {entry.id} has no {name} (files: {', '.join(sorted(entry.files)) or 'none'})")
    return entry.path(name)


@dataclass
class Entry:
    """One release entry: a garment instance x material x grasp point.

    Fields come from the entry's record (entry.json / catalog.sqlite); the methods read
    its files through the C++ readers.
    """

    id: str
    key: str
    split: str
    category: str
    garment: str
    instance: str
    material: str
    anchor: str            # anchor (grasp point) label, "" if unknown
    anchor_vertex: int     # index of the anchor vertex in hang.ply, -1 if unknown
    failed: bool
    failure: str
    record: Dict[str, Any] = field(repr=False)
    files: Dict[str, int] = field(repr=False)  # path relative to the entry folder -> bytes
    release: "Release" = field(repr=False, compare=False)

    def path(self, name: str = "") -> str:
        """Absolute path of a file of this entry (or of its folder)."""
        return os.path.join(self.release.path, "entries", self.id, name)  # as Release::EntryPath

    def hang_mesh(self, open3d: bool = False):
        """The stationary hung mesh (object frame: gripper at the origin, y up, metres):
        (V float64 (n, 3), F int32 (m, 3)), or an open3d.geometry.TriangleMesh."""
        return _mesh(self._read_mesh("hang.ply"), open3d)

    def recon_mesh(self, open3d: bool = False):
        """The mesh fused from the depth sweep (TSDF, marching cubes), object frame."""
        return _mesh(self._read_mesh("recon.ply"), open3d)

    def _read_mesh(self, name: str, vertex_dtype: str = "float64", face_dtype: str = "int32"):
        return _drape.read_mesh(_ensure(self, name), vertex_dtype, face_dtype)

    def feature(self):
        """The binary cylindrical feature: numpy bool (layers, rings, sectors)."""
        return _drape.read_feature(_ensure(self, "feature.bin"))

    def sdf(self) -> Dict[str, Any]:
        """The fused signed distance field of sdf.vdb as dense arrays (OpenVDB reader):
        {"sdf": float32 (X, Y, Z) metres (< 0 inside), "weight": float32 (X, Y, Z),
         "index_to_object": 4x4 (array index -> object-frame metres), "origin_index",
         "voxel_size", "truncation"}. Outside the array the field is +truncation."""
        return _drape.read_sdf(_ensure(self, "sdf.vdb"))

    def sweep(self) -> Dict[str, Any]:
        """The kept depth sweep: {"depth_mm": uint16 (frames, H, W) (0 = no data),
        "intrinsics": {width, height, fx, fy, cx, cy}, "camera_to_object" (frames, 4, 4),
        "camera_to_world" (frames, 4, 4), "gripper_angle" (frames,) radians}."""
        _ensure(self, "sweep/cameras.json")
        return _drape.read_sweep(self.path("sweep"))

    def preview(self):
        """The preview picture: uint8 (H, W, 3) RGB."""
        return _drape.read_image(_ensure(self, "preview.png"))


def _mesh(vf, open3d: bool):
    if not open3d:
        return vf
    import numpy as np
    import open3d as o3d
    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(vf[0]), o3d.utility.Vector3iVector(vf[1].astype(np.int32)))
    m.compute_vertex_normals()
    return m


@dataclass
class Recognition:
    """A recognition result (the same numbers `drape recognize --json` prints)."""

    category: str
    anchor: str
    entry: str                 # id of the matched database entry
    distance: int              # Eq. match distance, bits
    rotation: int              # best sector shift k
    score: float               # what was ranked (weighted or plain distance)
    weighted: bool
    top: List[Dict[str, Any]]  # best entry of each of the top-k anchors, best first
    anchor_position: Dict[str, Any]
    result: Dict[str, Any] = field(repr=False)  # the recognizer's full JSON result
    query: Dict[str, Any] = field(repr=False)


class Release:
    """A finished release (see open_release)."""

    def __init__(self, path: "str | os.PathLike[str]"):
        path = os.fspath(path)
        if not os.path.isdir(path):
            raise ReleaseNotFoundError(f"{path}: no such release folder")
        if not os.path.isfile(os.path.join(path, "dataset.json")):
            raise ReleaseNotFoundError(f"{path}: not a release (no dataset.json)")
        self.path = os.path.abspath(path)
        self._core = _drape.Release(self.path)
        self.metadata: Dict[str, Any] = json.loads(self._core.dataset_json())
        self._entries = [self._make_entry(j) for j in json.loads(self._core.entries_json())]
        self._by_id = {e.id: e for e in self._entries}
        self._runtimes: Dict[str, Any] = {}

    def __reduce__(self):  # DataLoader workers started with spawn re-open the folder
        return (Release, (self.path,))

    def __repr__(self) -> str:
        return f"<drape.Release {self.name} {self.version}: {len(self._entries)} entries at {self.path}>"

    def __len__(self) -> int:
        return len(self._entries)

    @property
    def name(self) -> str:
        return self.metadata.get("name", "")

    @property
    def version(self) -> str:
        return self.metadata.get("version", "")

    @property
    def digest(self) -> str:
        return self._core.digest()

    @property
    def splits(self) -> List[str]:
        """Split names present, train / calibration / test first."""
        order = {"train": 0, "calibration": 1, "test": 2}
        return sorted({e.split for e in self._entries}, key=lambda s: (order.get(s, 3), s))

    @property
    def categories(self) -> List[str]:
        return sorted({e.category for e in self._entries})

    @property
    def anchors(self) -> List[str]:
        """Sorted anchor labels over all entries."""
        return sorted({e.anchor for e in self._entries if e.anchor})

    def entries(self, split: Optional[str] = None, category: Optional[str] = None,
                include_failed: bool = False) -> List[Entry]:
        """Entries sorted by id, optionally of one split and/or category. Failed entries
        (kept in the catalog with their reason) only with include_failed=True.
        An unknown split or category raises DrapeError naming the ones there are."""
        if split is not None and split not in self.splits:
            raise DrapeError(f"{self.path}: no split '{split}' (this release has: {', '.join(self.splits)})")
        if category is not None and category not in self.categories:
            raise DrapeError(f"{self.path}: no category '{category}' (this release has: {', '.join(self.categories)})")
        return [e for e in self._entries
                if (split is None or e.split == split) and (category is None or e.category == category)
                and (include_failed or not e.failed)]

    def entry(self, id: str) -> Entry:
        try:
            return self._by_id[id]
        except KeyError:
            raise DrapeError(f"{self.path}: no entry '{id}'") from None

    def to_pandas(self):
        """The entries as a pandas DataFrame (needs pandas)."""
        import pandas as pd
        return pd.DataFrame([{k: getattr(e, k) for k in ("id", "split", "category", "garment", "instance",
                                                           "material", "anchor", "anchor_vertex", "failed")}
                             for e in self._entries])

    def recognize(self, *, entry: Optional[str] = None, sweep: Optional[str] = None, mesh=None, feature=None,
                  category: str = "", instance: str = "", top_k: int = 5, weighted: bool = True,
                  weights: str = "", seed: int = 0, category_fit: bool = True) -> Recognition:
        """Category and grasp point of a hung garment, against this release's train split
        (as `drape recognize`). Exactly one query:
          entry=ID      a release entry (its stored feature)
          sweep=DIR     a recorded sweep folder (16-bit depth PNGs + cameras.json)
          mesh=...      a hung mesh in the object frame: a file path, or (V, F) arrays
          feature=bits  a feature array (layers, rings, sectors)
        weights: "" = the release's calibration/weights.json if present, "none", or a path.
        category_fit: an entry= query with a reconstruction and no category takes its category by
          registration (as `drape recognize --entry`); False: the unweighted nearest neighbour."""
        given = [q is not None for q in (entry, sweep, mesh, feature)]
        if sum(given) != 1:
            raise DrapeError("recognize: give exactly one of entry=, sweep=, mesh=, feature=")
        rt = self._runtime(weights)
        if mesh is not None and not isinstance(mesh, (str, os.PathLike)):
            from ._runtime import _temp_ply
            with _temp_ply(mesh) as p:
                raw = rt.recognize("mesh", p, None, category, instance, top_k, weighted, seed, category_fit)
        else:
            kind, value = next((k, v) for k, v in (("entry", entry), ("sweep", sweep), ("mesh", mesh),
                                                    ("feature", feature)) if v is not None)
            raw = rt.recognize(kind, "" if kind == "feature" else os.fspath(value),
                               value if kind == "feature" else None, category, instance, top_k, weighted, seed,
                               category_fit)
        j = json.loads(raw)
        r = j["result"]
        b = r["best"]
        return Recognition(category=r["category"], anchor=r["anchor"], entry=b["entry"], distance=b["distance"],
                           rotation=b["rotation"], score=b["score"], weighted=r["weighted"], top=r["top"],
                           anchor_position=j["anchor_position"], result=r, query=j["query"])

    def extract_feature(self, *, sweep=None, mesh=None, seed: int = 0):
        """The feature of a recorded sweep folder or a hung mesh, computed by the query
        pipeline with this release's recipe options (fusion, feature shape)."""
        if (sweep is None) == (mesh is None):
            raise DrapeError("extract_feature: give exactly one of sweep=, mesh=")
        rt = self._runtime("")
        if mesh is not None and not isinstance(mesh, (str, os.PathLike)):
            from ._runtime import _temp_ply
            with _temp_ply(mesh) as p:
                return rt.pipeline_feature("mesh", p, seed)
        return rt.pipeline_feature("sweep" if sweep is not None else "mesh", os.fspath(sweep or mesh), seed)

    def _runtime(self, weights: str):
        if weights not in self._runtimes:
            self._runtimes[weights] = _drape.Runtime(self.path, weights)
        return self._runtimes[weights]

    def _make_entry(self, j: Dict[str, Any]) -> Entry:
        rec = j.get("record") or {}
        anchor = rec.get("anchor") if isinstance(rec.get("anchor"), dict) else {}
        return Entry(id=j["id"], key=j["key"], split=j["split"], category=str(rec.get("category", "")),
                     garment=str(rec.get("garment", "")), instance=str(rec.get("instance", "")),
                     material=str(rec.get("material", "")), anchor=str(anchor.get("label", "")),
                     anchor_vertex=int(anchor.get("vertex", -1)), failed=bool(j["failed"]),
                     failure=j.get("failure", ""), record=rec, files={f["path"]: f["size"] for f in j["files"]},
                     release=self)
