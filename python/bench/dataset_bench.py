#!/usr/bin/python3
"""Entries per second through drape.torch.GarmentDataset (features only; with both
meshes), next to reading the same files by hand with numpy (feature.bin) and Open3D
(hang.ply, recon.ply). A benchmark, not a test: it prints figures.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/dataset_bench.py build/quickstart [--passes 5]
"""

import argparse
import os
import time

import numpy as np


def feature_by_hand(path):
    data = open(path, "rb").read()
    _, n, r, phi, _ = np.frombuffer(data[4:24], dtype="<u4")
    bits = np.unpackbits(np.frombuffer(data[24:], dtype=np.uint8), bitorder="little")
    return bits[: n * r * phi].astype(bool).reshape(n, r, phi)


def rate(fn, n_items, passes):
    fn()  # warm the page cache and imports
    t0 = time.perf_counter()
    for _ in range(passes):
        fn()
    return n_items * passes / (time.perf_counter() - t0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("release")
    ap.add_argument("--split", default="train")
    ap.add_argument("--passes", type=int, default=5)
    a = ap.parse_args()

    import open3d as o3d
    import torch
    import drape
    from drape.torch import GarmentDataset, collate

    torch.set_num_threads(1)
    r = drape.open_release(a.release)
    entries = r.entries(split=a.split)
    n = len(entries)
    dirs = [os.path.join(r.path, "entries", e.id) for e in entries]

    def through(ds, workers=0):
        if workers == 0:
            return lambda: [ds[i] for i in range(len(ds))]
        dl = torch.utils.data.DataLoader(ds, batch_size=8, num_workers=workers, collate_fn=collate,
                                         persistent_workers=True)
        return lambda: [b for b in dl]

    def by_hand(meshes):
        def run():
            for d in dirs:
                f = feature_by_hand(os.path.join(d, "feature.bin"))
                if meshes:
                    for name in ("hang.ply", "recon.ply"):
                        m = o3d.io.read_triangle_mesh(os.path.join(d, name))
                        V, F = np.asarray(m.vertices), np.asarray(m.triangles)
        return run

    feat = GarmentDataset(r, a.split, fields=("feature",))
    mesh = GarmentDataset(r, a.split, fields=("feature", "hang_mesh", "recon_mesh"))
    rows = [
        ("features only", rate(through(feat), n, a.passes), rate(by_hand(False), n, a.passes)),
        ("features + hang + recon meshes", rate(through(mesh), n, a.passes), rate(by_hand(True), n, a.passes)),
    ]
    workers = [("features only, DataLoader 2 workers", rate(through(feat, 2), n, a.passes)),
               ("with meshes, DataLoader 2 workers", rate(through(mesh, 2), n, a.passes))]
    V = [e.recon_mesh()[0].shape[0] for e in entries[:5]]
    print(f"release {r.name} {r.version}, split {a.split}: {n} entries; recon meshes ~{int(np.mean(V))} vertices; "
          f"{a.passes} passes, warm page cache, load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"{'':34s} {'GarmentDataset':>16s} {'by hand (numpy/Open3D)':>24s}")
    for name, ds, hand in rows:
        print(f"{name:34s} {ds:12.0f} /s {hand:20.0f} /s")
    for name, ds in workers:
        print(f"{name:34s} {ds:12.0f} /s  (persistent workers, started in the warm-up pass)")


if __name__ == "__main__":
    main()
