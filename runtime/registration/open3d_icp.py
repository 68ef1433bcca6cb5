#!/usr/bin/python3
"""Open3D point-to-point ICP for registration_bench (run with Debian's /usr/bin/python3,
which has python3-open3d). Usage: open3d_icp.py SOURCE.xyz TARGET.xyz MAX_ITER
Prints one line: "seconds <t> fitness <f> rmse <r> iterations <n> T <16 numbers, row-major>".
"""
import sys
import time

import numpy as np
import open3d as o3d
from open3d import pipelines


def main():
    src = np.loadtxt(sys.argv[1]).reshape(-1, 3)
    dst = np.loadtxt(sys.argv[2]).reshape(-1, 3)
    max_iter = int(sys.argv[3])
    ps = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(src))
    pt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(dst))
    reg = pipelines.registration
    crit = reg.ICPConvergenceCriteria(relative_fitness=1e-9, relative_rmse=1e-9, max_iteration=max_iter)
    # Every correspondence is used (as in our ICP): a threshold larger than the scene.
    t0 = time.perf_counter()
    res = reg.registration_icp(ps, pt, 10.0, np.eye(4), reg.TransformationEstimationPointToPoint(False), crit)
    t = time.perf_counter() - t0
    T = np.asarray(res.transformation).reshape(-1)
    print("seconds %.6f fitness %.6f rmse %.9f iterations %d T %s" %
          (t, res.fitness, res.inlier_rmse, max_iter, " ".join("%.17g" % v for v in T)))


if __name__ == "__main__":
    main()
