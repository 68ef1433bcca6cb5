// numpy ↔ drape conversions shared by the binding sources (defined in module.cpp).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <string>

#include "common/mesh.h"
#include "generator/feature/feature.h"

namespace drape::python {

namespace py = pybind11;
using DoubleArray = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IndexArray = py::array_t<int64_t, py::array::c_style | py::array::forcecast>;
using BoolArray = py::array_t<bool, py::array::c_style | py::array::forcecast>;

py::array_t<double> ToArray(const Points3& V);
py::array_t<int32_t> ToArray(const Faces& F);
py::tuple MeshTuple(const TriMesh& m);  // (V, F)
// Throws drape::Error naming `what` on a wrong shape or an out-of-range face index.
TriMesh MeshFromArrays(const DoubleArray& V, const IndexArray& F, const std::string& what);
// bool (layers, rings, sectors); element [l, r, s] is bit (l·R + r)·Φ + s.
py::array_t<bool> FeatureToArray(const Feature& f);
Feature FeatureFromArray(const BoolArray& a, const std::string& what);

void BindRuntime(py::module_& m);  // runtime.cpp

}  // namespace drape::python
