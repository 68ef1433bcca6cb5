// Embree set-up shared by every stage that ray casts or queries closest points
// (generator/sweep, generator/fusion's accuracy, runtime/registration): one device
// configuration and one triangle-mesh geometry. Library drape_embree.
#pragma once

#include <embree3/rtcore.h>

#include <string>

#include "common/mesh.h"

namespace drape {

// The ISA a device asks for by default. Results do not depend on it: the sweep decides
// every ray–triangle hit and the closest-point query every distance in its own double
// arithmetic; Embree's tree only proposes candidates.
inline constexpr const char* kEmbreeIsa = "avx2";

// A device configured "threads=N[,isa=ISA]" ("" = Embree picks its best ISA). The
// caller releases it (rtcReleaseDevice). Throws drape::Error when Embree refuses
// (e.g. an ISA this CPU lacks), naming the configuration.
RTCDevice NewEmbreeDevice(const std::string& isa = kEmbreeIsa, int threads = 1);

// A committed triangle geometry holding float copies of mesh's vertices and faces;
// the caller attaches it to a scene and releases it.
RTCGeometry NewTriangleGeometry(RTCDevice device, const TriMesh& mesh);

}  // namespace drape
