// The gallery's 3D view: three.js files (npm package "three", version pinned in
// generator/release/viewer/package-lock.json, installed into the build folder by
// ./setup.sh) and drape-viewer.js are linked into the binary (.incbin), so every release
// gets the same bytes, written once per release under viewer/. Each entry's meshes go
// into viewer/meshes/<id>.js as gzip + base64 inside a classic script, because a page
// opened from file:// may load scripts but not fetch() files (gzip: the PLYs shrink to
// ~45 %; the browser inflates them with DecompressionStream).
#include <openssl/evp.h>
#include <zlib.h>

#include "common/error.h"
#include "common/files.h"
#include "generator/release/release_internal.h"

#if DRAPE_GALLERY_3D
#define DRAPE_INCBIN(name, file)                                                                 \
  __asm__(".section .rodata\n.balign 16\n.hidden " #name "_begin\n.hidden " #name "_end\n" #name \
          "_begin:\n.incbin \"" file "\"\n" #name "_end:\n.previous\n");                         \
  extern "C" const char name##_begin[], name##_end[];

DRAPE_INCBIN(drape_three_js, DRAPE_THREE_DIR "/build/three.min.js")
DRAPE_INCBIN(drape_three_ply, DRAPE_THREE_DIR "/examples/js/loaders/PLYLoader.js")
DRAPE_INCBIN(drape_three_orbit, DRAPE_THREE_DIR "/examples/js/controls/OrbitControls.js")
DRAPE_INCBIN(drape_three_license, DRAPE_THREE_DIR "/LICENSE")
DRAPE_INCBIN(drape_viewer_js, DRAPE_VIEWER_JS)
#endif

namespace fs = std::filesystem;

namespace drape::release_detail {
namespace {

#if DRAPE_GALLERY_3D  // only the 3D gallery's mesh scripts encode
std::string Base64(const std::string& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()),
                                reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<int>(bytes.size()));
  out.resize(n);
  return out;
}

// gzip with a zero mtime and no name: the same bytes on every machine.
std::string Gzip(const std::string& bytes) {
  z_stream z{};
  DRAPE_CHECK(deflateInit2(&z, 9, Z_DEFLATED, 15 + 16, 9, Z_DEFAULT_STRATEGY) == Z_OK, "deflateInit2");
  std::string out(deflateBound(&z, bytes.size()) + 32, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data()));
  z.avail_in = static_cast<uInt>(bytes.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  deflateEnd(&z);
  DRAPE_CHECK(rc == Z_STREAM_END, "deflate");
  out.resize(z.total_out);
  return out;
}
#endif

bool Has(const Release::EntryInfo& e, const std::string& path) {
  for (const auto& f : e.files)
    if (f.path == path) return true;
  return false;
}

}  // namespace

bool GalleryHas3d() { return DRAPE_GALLERY_3D != 0; }

bool EntryHas3d(const Release::EntryInfo& e) {
  return GalleryHas3d() && !e.failed && Has(e, "hang.ply") && Has(e, "recon.ply");
}

// dir and entries are unused in a build without three.js (DRAPE_GALLERY_3D 0, e.g. the
// sanitizer build), whose galleries have no 3D view.
std::vector<std::pair<std::string, std::string>> GalleryViewerFiles(
    [[maybe_unused]] const fs::path& dir, [[maybe_unused]] const std::vector<Release::EntryInfo>& entries) {
  std::vector<std::pair<std::string, std::string>> files;
#if DRAPE_GALLERY_3D
  auto blob = [](const char* b, const char* e) { return std::string(b, static_cast<size_t>(e - b)); };
  files.emplace_back("viewer/three.min.js", blob(drape_three_js_begin, drape_three_js_end));
  files.emplace_back("viewer/PLYLoader.js", blob(drape_three_ply_begin, drape_three_ply_end));
  files.emplace_back("viewer/OrbitControls.js", blob(drape_three_orbit_begin, drape_three_orbit_end));
  files.emplace_back("viewer/LICENSE.three.txt", blob(drape_three_license_begin, drape_three_license_end));
  files.emplace_back("viewer/drape-viewer.js", blob(drape_viewer_js_begin, drape_viewer_js_end));
  for (const auto& e : entries) {
    if (!EntryHas3d(e)) continue;
    const Json a = e.record.is_object() && e.record.contains("anchor") ? e.record["anchor"] : Json::object();
    const int vertex =
        a.is_object() && a.contains("vertex") && a["vertex"].is_number_integer() ? a["vertex"].get<int>() : -1;
    auto mesh = [&](const char* name) { return Base64(Gzip(ReadFile(dir / "entries" / e.id / name))); };
    std::string js = "drapeViewerData(" + Json(e.id).dump() + ",{\"anchor_vertex\":" + std::to_string(vertex) +
                     ",\"encoding\":\"gzip+base64\",\"hang\":\"" + mesh("hang.ply") + "\",\"recon\":\"" +
                     mesh("recon.ply") + "\"});\n";
    files.emplace_back("viewer/meshes/" + e.id + ".js", std::move(js));
  }
#endif
  return files;
}

}  // namespace drape::release_detail
