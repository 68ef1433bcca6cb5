#!/usr/bin/python3
"""Entries per second through drape.torch.GarmentDataset (features only; with both
meshes), next to reading the same files by hand with numpy (feature.bin) and Open3D
(hang.ply, recon.ply), and the meshes alone: drape's reader against Open3D + numpy on
the same files. A benchmark, not a test: it prints figures.

    PYTHONPATH=build/python /usr/bin/python3 python/bench/dataset_bench.py build/quickstart [--passes 5]

On a shared machine wall rates count other processes' time: the CPU rates (this
process's CPU time) are the ones to compare, and the two sides of each row run
alternately, pass by pass, so both see the same load.
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


def rates(fns, n_items, passes):
    """Items per second (wall, CPU) of each function, run alternately pass by pass."""
    for fn in fns:
        fn()  # warm the page cache and imports
    wall = [0.0] * len(fns)
    cpu = [0.0] * len(fns)
    for _ in range(passes):
        for k, fn in enumerate(fns):
            w0, c0 = time.perf_counter(), time.process_time()
            fn()
            wall[k] += time.perf_counter() - w0
            cpu[k] += time.process_time() - c0
    return [(n_items * passes / w, n_items * passes / max(c, 1e-9)) for w, c in zip(wall, cpu)]


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

    def o3d_mesh(path):
        m = o3d.io.read_triangle_mesh(path)
        return np.asarray(m.vertices), np.asarray(m.triangles)

    # Every reader keeps what it read for the pass, as a Dataset's consumer does (memory
    # freed at once and reused would hide the cost of fresh pages).
    def by_hand(meshes):
        def run():
            out = []
            for d in dirs:
                item = [feature_by_hand(os.path.join(d, "feature.bin"))]
                if meshes:
                    item += [o3d_mesh(os.path.join(d, name)) for name in ("hang.ply", "recon.ply")]
                out.append(item)
            return out
        return run

    def meshes_drape():
        return [(e.hang_mesh(), e.recon_mesh()) for e in entries]

    def meshes_o3d():
        return [(o3d_mesh(os.path.join(d, "hang.ply")), o3d_mesh(os.path.join(d, "recon.ply"))) for d in dirs]

    feat = GarmentDataset(r, a.split, fields=("feature",))
    mesh = GarmentDataset(r, a.split, fields=("feature", "hang_mesh", "recon_mesh"))
    rows = [
        ("features only", *rates([through(feat), by_hand(False)], n, a.passes)),
        ("features + hang + recon meshes", *rates([through(mesh), by_hand(True)], n, a.passes)),
        ("hang + recon meshes alone", *rates([meshes_drape, meshes_o3d], n, a.passes)),
    ]
    workers = [("features only, DataLoader 2 workers", rates([through(feat, 2)], n, a.passes)[0]),
               ("with meshes, DataLoader 2 workers", rates([through(mesh, 2)], n, a.passes)[0])]
    V = [e.recon_mesh()[0].shape[0] for e in entries[:5]]
    print(f"release {r.name} {r.version}, split {a.split}: {n} entries; recon meshes ~{int(np.mean(V))} vertices; "
          f"{a.passes} passes, warm page cache, load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"entries per second, wall (CPU of this process); ratio = drape / by hand, CPU")
    print(f"{'':34s} {'drape':>20s} {'by hand (numpy/Open3D)':>24s} {'ratio':>6s}")
    for name, (dw, dc), (hw, hc) in rows:
        print(f"{name:34s} {dw:9.0f} ({dc:6.0f}) /s {hw:13.0f} ({hc:6.0f}) /s {dc / hc:6.2f}")
    for name, (w, _) in workers:
        print(f"{name:34s} {w:9.0f} /s (wall; persistent workers, started in the warm-up pass)")


if __name__ == "__main__":
    main()
