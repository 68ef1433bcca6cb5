"""drape.torch.GarmentDataset with a DataLoader and worker processes."""

import numpy as np
import pytest
import torch
from torch.utils.data import DataLoader

import drape
from drape.torch import GarmentDataset, collate


def test_item_layout(release):
    ds = GarmentDataset(release, "train", fields=("feature", "hang_mesh", "recon_mesh", "sdf", "preview"))
    assert len(ds) == 4 and ds.categories == ["towel"]
    it = ds[1]
    e = release.entries(split="train")[1]
    assert it["id"] == e.id and it["index"] == 1
    assert it["category"].item() == 0 and ds.anchors[it["anchor"].item()] == e.anchor
    assert it["feature"].dtype == torch.bool and torch.equal(it["feature"], torch.from_numpy(e.feature()))
    V, F = e.hang_mesh()
    assert it["hang_mesh"]["vertices"].dtype == torch.float32 and it["hang_mesh"]["vertices"].shape == V.shape
    assert torch.equal(it["hang_mesh"]["vertices"], torch.from_numpy(V.astype(np.float32)))
    assert torch.equal(it["hang_mesh"]["faces"], torch.from_numpy(F.astype(np.int64)))
    R, G = e.recon_mesh()
    assert torch.equal(it["recon_mesh"]["vertices"], torch.from_numpy(R.astype(np.float32)))
    assert torch.equal(it["recon_mesh"]["faces"], torch.from_numpy(G.astype(np.int64)))
    assert it["sdf"].ndim == 3 and it["sdf_index_to_object"].shape == (4, 4)
    assert it["preview"].dtype == torch.uint8
    t = GarmentDataset(release, "test", fields=("sweep",))[0]
    assert t["sweep"].dtype == torch.int32 and t["sweep"].shape[0] == 12


@pytest.mark.parametrize("fields", [("feature",), ("feature", "hang_mesh", "recon_mesh")])
def test_dataloader_two_workers(release, fields):
    ds = GarmentDataset(release, "train", fields=fields)
    dl = DataLoader(ds, batch_size=3, num_workers=2, collate_fn=collate)
    seen = []
    for batch in dl:
        assert batch["feature"].shape[1:] == (16, 16, 16) and batch["feature"].dtype == torch.bool
        assert batch["category"].dtype == torch.int64
        for i, id in enumerate(batch["id"]):
            np.testing.assert_array_equal(batch["feature"][i].numpy(), release.entry(id).feature())
            if "hang_mesh" in fields:
                assert batch["hang_mesh"][i]["vertices"].shape[0] == release.entry(id).hang_mesh()[0].shape[0]
        seen += batch["id"]
    assert seen == [e.id for e in release.entries(split="train")]


def test_default_collate_for_features(release):
    dl = DataLoader(GarmentDataset(release.path, "test"), batch_size=2, num_workers=2)
    b = next(iter(dl))
    assert b["feature"].shape == (2, 16, 16, 16) and list(b["id"]) == [e.id for e in release.entries(split="test")]


def test_bad_split_and_field(release):
    with pytest.raises(drape.DrapeError, match="no split 'validation'"):
        GarmentDataset(release, "validation")
    with pytest.raises(drape.DrapeError, match="unknown field"):
        GarmentDataset(release, "train", fields=("mesh",))
