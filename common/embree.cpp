#include "common/embree.h"

#include "common/error.h"

namespace drape {

RTCDevice NewEmbreeDevice(const std::string& isa, int threads) {
  std::string config = "threads=" + std::to_string(threads);
  if (!isa.empty()) config += ",isa=" + isa;
  RTCDevice device = rtcNewDevice(config.c_str());
  if (!device) throw Error("Embree: rtcNewDevice(\"" + config + "\") failed");
  if (const RTCError e = rtcGetDeviceError(device); e != RTC_ERROR_NONE) {
    rtcReleaseDevice(device);
    throw Error("Embree: rtcNewDevice(\"" + config + "\") failed with error " + std::to_string(int(e)));
  }
  return device;
}

RTCGeometry NewTriangleGeometry(RTCDevice device, const TriMesh& mesh) {
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                         3 * sizeof(float), mesh.NumVertices()));
  for (int v = 0; v < mesh.NumVertices(); ++v)
    for (int k = 0; k < 3; ++k) vb[3 * v + k] = static_cast<float>(mesh.V(v, k));
  auto* ib = static_cast<unsigned*>(
      rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.NumFaces()));
  for (int f = 0; f < mesh.NumFaces(); ++f)
    for (int k = 0; k < 3; ++k) ib[3 * f + k] = static_cast<unsigned>(mesh.F(f, k));
  rtcCommitGeometry(geom);
  return geom;
}

}  // namespace drape
