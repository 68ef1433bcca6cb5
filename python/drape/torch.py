"""PyTorch access to a release: drape.torch.GarmentDataset (needs python3-torch).

Item layout (a dict; only the fields asked for, plus the labels that are always there):

  "id"            str    entry id
  "index"         int    position in the dataset
  "category"      int64  index into dataset.categories (all categories of the release)
  "anchor"        int64  index into dataset.anchors (all anchor labels of the release)
  fields=
  "feature"       bool    (layers, rings, sectors)   the binary cylindrical feature
  "hang_mesh"     {"vertices": float32 (V, 3), "faces": int64 (F, 3)}  hung mesh, object frame
  "recon_mesh"    {"vertices": float32 (V, 3), "faces": int64 (F, 3)}  fused mesh
  "sdf"           float32 (X, Y, Z), with "sdf_index_to_object" float64 (4, 4)
  "preview"       uint8   (H, W, 3) RGB
  "sweep"         int32   (frames, H, W) depth in mm (torch 1.13 has no uint16),
                  with "sweep_camera_to_object" float64 (frames, 4, 4)

Fixed-size fields stack into batches with the default collate; meshes and SDFs differ
in size per entry, so with them use collate=drape.torch.collate (keeps those as lists):

    ds = GarmentDataset(release, "train", fields=("feature", "hang_mesh"))
    dl = torch.utils.data.DataLoader(ds, batch_size=8, num_workers=2, collate_fn=collate)
"""

from __future__ import annotations

from typing import Any, Dict, List, Sequence

import numpy as np
import torch
import torch.utils.data

from ._drape import DrapeError
from ._release import Release, open_release

FIELDS = ("feature", "hang_mesh", "recon_mesh", "sdf", "preview", "sweep")
_VARIABLE = ("hang_mesh", "recon_mesh", "sdf", "sdf_index_to_object", "sweep", "sweep_camera_to_object", "id")


class GarmentDataset(torch.utils.data.Dataset):
    """The non-failed entries of one split of a release, in id order."""

    def __init__(self, release, split: str, fields: Sequence[str] = ("feature",), category: str | None = None):
        self.release: Release = release if isinstance(release, Release) else open_release(release)
        unknown = [f for f in fields if f not in FIELDS]
        if unknown:
            raise DrapeError(f"GarmentDataset: unknown field(s) {unknown} (known: {', '.join(FIELDS)})")
        self.fields = tuple(fields)
        self.split = split
        self.entries = self.release.entries(split=split, category=category)
        self.categories: List[str] = self.release.categories
        self.anchors: List[str] = self.release.anchors

    def __len__(self) -> int:
        return len(self.entries)

    def __getitem__(self, i: int) -> Dict[str, Any]:
        e = self.entries[i]
        item: Dict[str, Any] = {
            "id": e.id,
            "index": i,
            "category": torch.tensor(self.categories.index(e.category), dtype=torch.int64),
            "anchor": torch.tensor(self.anchors.index(e.anchor) if e.anchor else -1, dtype=torch.int64),
        }
        for f in self.fields:
            if f == "feature":
                item["feature"] = torch.from_numpy(e.feature())
            elif f in ("hang_mesh", "recon_mesh"):
                V, F = e._read_mesh("hang.ply" if f == "hang_mesh" else "recon.ply", "float32", "int64")
                item[f] = {"vertices": torch.from_numpy(V), "faces": torch.from_numpy(F)}
            elif f == "sdf":
                s = e.sdf()
                item["sdf"] = torch.from_numpy(s["sdf"])
                item["sdf_index_to_object"] = torch.from_numpy(s["index_to_object"])
            elif f == "preview":
                item["preview"] = torch.from_numpy(e.preview())
            elif f == "sweep":
                s = e.sweep()
                item["sweep"] = torch.from_numpy(s["depth_mm"].astype(np.int32))
                item["sweep_camera_to_object"] = torch.from_numpy(s["camera_to_object"])
        return item


def collate(batch: List[Dict[str, Any]]) -> Dict[str, Any]:
    """Stacks fixed-size fields (labels, feature, preview); keeps per-entry meshes,
    SDFs, sweeps and ids as lists."""
    out: Dict[str, Any] = {}
    for k in batch[0]:
        values = [b[k] for b in batch]
        out[k] = values if k in _VARIABLE else torch.utils.data.default_collate(values)
    return out
