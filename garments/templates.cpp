#include "garments/templates.h"

#include <cmath>
#include <functional>
#include <iomanip>
#include <sstream>

#include "common/error.h"
#include "common/field_error.h"
#include "common/format.h"
#include "common/hash.h"
#include "common/rng.h"

namespace drape {
namespace {

using Params = std::map<std::string, double>;

// An outline under construction: points counter-clockwise, edge i from point i to i+1.
struct Builder {
  Contour c;
  std::vector<AnchorSpec> anchors;
  // Round-off like cos(π/2) = 6e-17 → 0: keeps coordinates exact through text formats.
  static Vec2 Clean(Vec2 p) {
    for (int k = 0; k < 2; ++k)
      if (std::abs(p[k]) < 1e-12) p[k] = 0;
    return p;
  }
  // Appends point p; the edge from p to the next point gets `tag`.
  void Add(const Vec2& p, const std::string& tag = "") {
    c.points.push_back(Clean(p));
    c.edge_tag.push_back(tag);
  }
  // The back layer's edge of opening `tag`: `from` and `to` (the opening's corners, in
  // outline order) and the points between them.
  void BackEdge(const std::string& tag, const Vec2& from, const std::vector<Vec2>& between, const Vec2& to) {
    auto& e = c.back_openings[tag];
    e.push_back(Clean(from));
    for (const Vec2& p : between) e.push_back(Clean(p));
    e.push_back(Clean(to));
  }
  void Anchor(const std::string& label, const Vec2& uv) { anchors.push_back({label, uv}); }
};

Vec2 Lerp(const Vec2& a, const Vec2& b, double t) { return a + t * (b - a); }
Vec2 MirrorX(const Vec2& p) { return Vec2(-p.x(), p.y()); }

void Require(bool ok, const std::string& what) {
  if (!ok) throw Error("parameters: " + what);
}

// The shirt's back neckline between the neck points (left at +x, H high) to the depth bd
// below them: a parabola that leaves the neck points ~25° below the horizontal, not
// tangent to the front's half ellipse (which leaves them straight down), so the cloth
// between the two necklines meshes without slivers.
void ShirtBackNeck(Builder& b, const Vec2& neck, double bd, double h) {
  const double nw = 2 * neck.x(), H = neck.y();
  const int kBack = 2 * std::max(2, static_cast<int>(std::ceil((nw + bd) / (2 * h))));  // even: a centre point
  std::vector<Vec2> back;
  for (int k = 1; k < kBack; ++k) {
    const double x = nw / 2 * (1 - 2.0 * k / kBack);  // from the left neck point (+x) to the right
    back.push_back(Vec2(x, H - bd * (1 - (2 * x / nw) * (2 * x / nw))));
  }
  b.BackEdge("neck", neck, back, MirrorX(neck));
}

// The shirt's back hem `drop` below the front's (the left hem corner `hem` at +x, y = 0):
// the vent down from the right hem corner, the back hem across (points about one target
// edge h apart, an even count: one at the centre), the vent up to the left corner.
void ShirtBackHem(Builder& b, const Vec2& hem, double drop, double h) {
  const double hw = 2 * hem.x();
  const int k_across = 2 * std::max(1, static_cast<int>(std::ceil(hw / (2 * h))));
  std::vector<Vec2> back;
  for (int k = 0; k <= k_across; ++k) back.push_back(Vec2(-hw / 2 + hw * k / k_across, -drop));
  b.BackEdge("hem", MirrorX(hem), back, hem);
}

// Shirts (long sleeve and T-shirt) share one outline: body, shoulders, a curved
// neckline, and sleeves pointing down-outwards at sleeve_angle below horizontal. The
// back neckline is a shallow parabola between the same neck points (its depth
// neck_depth − back_neck_rise), as shirts are drafted; back_neck_rise = 0 makes the
// back the front's mirror there. back_hem_drop > 0 gives the back a longer hem, as a
// polo shirt's "tennis tail": straight across, back_hem_drop below the front's, the side
// seams open below the front's hem corners (vents as long as the drop); 0 (every
// preset): the back hem is the front's.
Builder Shirt(const Params& p, double h, bool long_sleeve) {
  const double H = p.at("body_length"), cw = p.at("chest_width"), hw = p.at("hem_width");
  const double sw = p.at("shoulder_width"), nw = p.at("neck_width"), nd = p.at("neck_depth");
  const double sd = p.at("shoulder_drop"), ad = p.at("armhole_depth");
  const double sl = p.at("sleeve_length"), cuff = p.at("sleeve_width"), ang = p.at("sleeve_angle");
  const double rise = p.at("back_neck_rise"), hem_drop = p.at("back_hem_drop");
  Require(hem_drop < ad, "back_hem_drop must be smaller than armhole_depth");
  Require(nw < sw, "neck_width must be smaller than shoulder_width");
  Require(rise <= nd, "back_neck_rise must not exceed neck_depth (the back neckline above the neck points)");
  Require(nd < ad && sd < ad, "neck_depth and shoulder_drop must be smaller than armhole_depth");
  Require(ad < H, "armhole_depth must be smaller than body_length");
  const Vec2 hem(hw / 2, 0), armpit(cw / 2, H - ad), shoulder(sw / 2, H - sd), neck(nw / 2, H);
  const Vec2 d(std::cos(ang), -std::sin(ang));   // along the sleeve
  const Vec2 n(-std::sin(ang), -std::cos(ang));  // across the sleeve, towards its underside
  const Vec2 cuff_top = shoulder + sl * d, cuff_bottom = cuff_top + cuff * n;
  Require(cuff_bottom.y() > 0.02, "the sleeve reaches below the hem (sleeve_length/sleeve_angle)");
  Require(cuff_bottom.x() > armpit.x(), "the sleeve is too short to clear the body");
  const std::string cuff_l = long_sleeve ? "left_cuff" : "left_sleeve";
  const std::string cuff_r = long_sleeve ? "right_cuff" : "right_sleeve";

  Builder b;
  // Right half of the picture (wearer's left), bottom up.
  b.Add(hem);
  b.Add(armpit);
  b.Add(cuff_bottom, cuff_l);
  b.Add(cuff_top);
  b.Add(shoulder);
  // Neckline: half ellipse from the left neck point through the collar to the right,
  // in pieces about one target edge long (at least 4, so it stays a curve).
  const double arc = M_PI * (nw / 2 + nd) / 2;  // ≈ half the ellipse perimeter
  const int kNeck = std::max(4, static_cast<int>(std::ceil(arc / h)));
  for (int k = 0; k < kNeck; ++k) {
    const double t = M_PI * k / kNeck;
    b.Add(Vec2(nw / 2 * std::cos(t), H - nd * std::sin(t)), "neck");
  }
  b.Add(MirrorX(neck));
  b.Add(MirrorX(shoulder));
  if (rise > 0) ShirtBackNeck(b, neck, nd - rise, h);
  b.Add(MirrorX(cuff_top), cuff_r);
  b.Add(MirrorX(cuff_bottom));
  b.Add(MirrorX(armpit));
  b.Add(MirrorX(hem), "hem");
  if (hem_drop > 0) ShirtBackHem(b, hem, hem_drop, h);

  const double chest_y = H - ad;
  b.Anchor("collar", Vec2(0, H - nd));
  b.Anchor("left_neck", neck);
  b.Anchor("right_neck", MirrorX(neck));
  b.Anchor("left_shoulder", shoulder);
  b.Anchor("right_shoulder", MirrorX(shoulder));
  b.Anchor("left_armpit", armpit);
  b.Anchor("right_armpit", MirrorX(armpit));
  if (long_sleeve) {
    const Vec2 elbow = 0.5 * (Lerp(shoulder, cuff_top, 0.5) + Lerp(armpit, cuff_bottom, 0.5));
    b.Anchor("left_elbow", elbow);
    b.Anchor("right_elbow", MirrorX(elbow));
  }
  const Vec2 cuff_mid = 0.5 * (cuff_top + cuff_bottom);
  b.Anchor(long_sleeve ? "left_cuff" : "left_sleeve_end", cuff_mid);
  b.Anchor(long_sleeve ? "right_cuff" : "right_sleeve_end", MirrorX(cuff_mid));
  b.Anchor("chest_center", Vec2(0, chest_y));
  b.Anchor("left_chest", Vec2(cw / 4, chest_y));
  b.Anchor("right_chest", Vec2(-cw / 4, chest_y));
  const Vec2 waist = Lerp(hem, armpit, 0.4);
  b.Anchor("left_waist", waist);
  b.Anchor("right_waist", MirrorX(waist));
  b.Anchor("hem_center", Vec2(0, 0));
  b.Anchor("left_hem", hem);
  b.Anchor("right_hem", MirrorX(hem));
  return b;
}

// Pants and shorts: waistband on top, two legs meeting at the crotch. The back waist
// rises to back_waist_rise above the front's at the centre (a half ellipse between the
// waist corners), as trousers are drafted: the back rise is the longer. Front and back
// share the side seams, inseams and crotch point, so in this two-layer flat pattern the
// back crotch curve's extra length shows as that higher back waist. back_waist_rise = 0
// makes the back the front's mirror.
Builder Trousers(const Params& p, double h, bool shorts) {
  const double ww = p.at("waist_width"), hipw = p.at("hip_width"), rise = p.at("rise");
  const double hd = p.at("hip_depth"), inseam = p.at("inseam"), lw = p.at("leg_width");
  const double gap = p.at("leg_gap"), back_rise = p.at("back_waist_rise");
  Require(hd < rise, "hip_depth must be smaller than rise");
  Require(gap > 0.005, "leg_gap must be at least 5 mm");
  const double H = rise + inseam;
  const double xc = gap / 2 + lw / 2;  // centre of a leg opening
  const Vec2 waist(ww / 2, H), hip(hipw / 2, H - hd), crotch(0, inseam);
  const Vec2 leg_out(gap / 2 + lw, 0), leg_in(gap / 2, 0);
  Builder b;
  b.Add(leg_in, "left_leg");
  b.Add(leg_out);
  b.Add(hip);
  b.Add(waist, "waist");
  b.Add(MirrorX(waist));
  b.Add(MirrorX(hip));
  b.Add(MirrorX(leg_out), "right_leg");
  b.Add(MirrorX(leg_in));
  b.Add(crotch);
  if (back_rise > 0) {
    // A half ellipse: it leaves the waist corners straight up (at a right angle to the
    // front's waist), so the cloth between the two waists meshes without slivers (but
    // within a few cm of the corners it is thinner than the edge length: edges there
    // down to 0.35 of it, templates_test).
    // Points evenly spaced in x (evenly in angle would crowd them at the corners, where
    // the flat ellipse runs nearly straight up); an even count puts one at the centre.
    const int kBack = 2 * std::max(2, static_cast<int>(std::ceil(ww / (2 * h))));
    std::vector<Vec2> back;
    for (int k = 1; k < kBack; ++k) {
      const double u = 1 - 2.0 * k / kBack;  // from the left waist corner (u = 1, +x) to the right
      back.push_back(Vec2(ww / 2 * u, H + back_rise * std::sqrt(std::max(0.0, 1 - u * u))));
    }
    b.BackEdge("waist", waist, back, MirrorX(waist));
  }

  b.Anchor("waist_center", Vec2(0, H));
  b.Anchor("left_waist", waist);
  b.Anchor("right_waist", MirrorX(waist));
  if (!shorts) {
    b.Anchor("left_hip", hip);
    b.Anchor("right_hip", MirrorX(hip));
  }
  b.Anchor("crotch", crotch);
  if (!shorts) {
    // Knee: on the leg's centre line, 45 % of the inseam above the leg opening.
    const Vec2 knee = Lerp(Vec2(xc, 0), Vec2(hipw / 4, inseam), 0.45);
    b.Anchor("left_knee", knee);
    b.Anchor("right_knee", MirrorX(knee));
  }
  b.Anchor("left_leg_outer", leg_out);
  b.Anchor("left_leg_inner", leg_in);
  b.Anchor("right_leg_outer", MirrorX(leg_out));
  b.Anchor("right_leg_inner", MirrorX(leg_in));
  return b;
}

Builder Skirt(const Params& p, double) {
  const double ww = p.at("waist_width"), hipw = p.at("hip_width"), hd = p.at("hip_depth");
  const double hw = p.at("hem_width"), L = p.at("length");
  Require(hd < L, "hip_depth must be smaller than length");
  const Vec2 hem(hw / 2, 0), hip(hipw / 2, L - hd), waist(ww / 2, L);
  Builder b;
  b.Add(hem);
  b.Add(hip);
  b.Add(waist, "waist");
  b.Add(MirrorX(waist));
  b.Add(MirrorX(hip));
  b.Add(MirrorX(hem), "hem");
  b.Anchor("waist_center", Vec2(0, L));
  b.Anchor("left_waist", waist);
  b.Anchor("right_waist", MirrorX(waist));
  b.Anchor("left_hip", hip);
  b.Anchor("right_hip", MirrorX(hip));
  b.Anchor("hem_center", Vec2(0, 0));
  b.Anchor("left_hem", hem);
  b.Anchor("right_hem", MirrorX(hem));
  return b;
}

// A towel has no wearer: its left/right are as seen in the preview (−x / +x).
Builder Towel(const Params& p, double) {
  const double w = p.at("width"), l = p.at("length");
  Builder b;
  b.Add(Vec2(-w / 2, 0));
  b.Add(Vec2(w / 2, 0));
  b.Add(Vec2(w / 2, l));
  b.Add(Vec2(-w / 2, l));
  b.Anchor("top_left", Vec2(-w / 2, l));
  b.Anchor("top_center", Vec2(0, l));
  b.Anchor("top_right", Vec2(w / 2, l));
  b.Anchor("left_center", Vec2(-w / 2, l / 2));
  b.Anchor("center", Vec2(0, l / 2));
  b.Anchor("right_center", Vec2(w / 2, l / 2));
  b.Anchor("bottom_left", Vec2(-w / 2, 0));
  b.Anchor("bottom_center", Vec2(0, 0));
  b.Anchor("bottom_right", Vec2(w / 2, 0));
  return b;
}

struct TemplateDef {
  TemplateInfo info;
  std::function<Builder(const Params&, double)> build;
};

std::vector<TemplateParameter> ShirtParams(bool long_sleeve) {
  std::vector<TemplateParameter> v = {
      {"chest_width", "flat width of the body at the armpits", 0.48, 0.52, 0.56},
      {"hem_width", "flat width at the hem", 0.46, 0.50, 0.54},
      {"body_length", "height from the neck points down to the hem", 0.68, 0.72, 0.76},
      {"shoulder_width", "distance between the shoulder points", 0.42, 0.46, 0.50},
      {"neck_width", "distance between the neck points", 0.17, 0.18, 0.19},
      {"neck_depth", "depth of the front neckline below the neck points", 0.07, 0.08, 0.09},
      {"shoulder_drop", "height of the neck points above the shoulder points", 0.04, 0.045, 0.05},
      {"armhole_depth", "height of the neck points above the armpits", 0.22, 0.24, 0.26},
  };
  if (long_sleeve) {
    v.push_back({"sleeve_length", "shoulder point to cuff, along the sleeve's top edge", 0.58, 0.62, 0.65});
    v.push_back({"sleeve_width", "flat width of the cuff opening", 0.10, 0.11, 0.12});
    v.push_back({"sleeve_angle", "sleeve direction below horizontal (radians)", 0.5, 0.5, 0.5, true});
  } else {
    v[2] = {"body_length", "height from the neck points down to the hem", 0.66, 0.70, 0.74};
    v.push_back({"sleeve_length", "shoulder point to sleeve end, along the sleeve's top edge", 0.18, 0.20, 0.22});
    v.push_back({"sleeve_width", "flat width of the sleeve opening", 0.15, 0.16, 0.17});
    v.push_back({"sleeve_angle", "sleeve direction below horizontal (radians)", 0.35, 0.35, 0.35, true});
  }
  // Front neck drop ≈ 7–9 cm, back ≈ 2 cm (scaled with size), as shirts are drafted.
  v.push_back({"back_neck_rise",
               "how much higher the back neckline's lowest point is than the front's (the back neck "
               "depth is neck_depth minus this; 0: the back neckline is the front's)",
               0.052, 0.060, 0.068});
  // Off in every preset: dress shirts hang the same length front and back, sweaters'
  // ribbed hems are straight round; polo shirts' back is 1" longer (garments/anchors.md).
  // Appended last, so the seeded perturbation's draws of the others are unchanged (0 stays 0).
  v.push_back({"back_hem_drop",
               "how much lower the back hem is than the front's (straight across, the side seams "
               "open below the front's hem corners; 0: the back hem is the front's)",
               0, 0, 0});
  return v;
}

// Appended last: the seeded perturbation draws the parameters in order, so the others
// keep their values.
constexpr const char* kBackWaistRise =
    "how much higher the back waist's centre is than the front's (the back rise is rise plus "
    "this; 0: the back waist is the front's)";

std::vector<TemplateParameter> TrouserParams(bool shorts) {
  if (!shorts) {
    return {
        {"waist_width", "flat width of the waistband", 0.38, 0.40, 0.43},
        {"hip_width", "flat width at the hips", 0.48, 0.51, 0.54},
        {"hip_depth", "waist to hip line", 0.16, 0.17, 0.18},
        {"rise", "waist to crotch (front)", 0.26, 0.28, 0.30},
        {"inseam", "height of the crotch above the leg openings", 0.74, 0.78, 0.82},
        {"leg_width", "flat width of a leg opening", 0.18, 0.19, 0.20},
        {"leg_gap", "distance between the inner corners of the two leg openings", 0.12, 0.12, 0.12},
        {"back_waist_rise", kBackWaistRise, 0.03, 0.035, 0.04},
    };
  }
  return {
      {"waist_width", "flat width of the waistband", 0.38, 0.40, 0.43},
      {"hip_width", "flat width at the hips", 0.50, 0.53, 0.56},
      {"hip_depth", "waist to hip line", 0.16, 0.17, 0.18},
      {"rise", "waist to crotch (front)", 0.26, 0.28, 0.30},
      {"inseam", "height of the crotch above the leg openings", 0.16, 0.18, 0.20},
      {"leg_width", "flat width of a leg opening", 0.27, 0.29, 0.31},
      {"leg_gap", "distance between the inner corners of the two leg openings", 0.04, 0.04, 0.04},
      {"back_waist_rise", kBackWaistRise, 0.03, 0.035, 0.04},
  };
}

std::vector<std::string> Labels(const Builder& b) {
  std::vector<std::string> v;
  for (const auto& a : b.anchors) v.push_back(a.label);
  return v;
}

std::vector<std::string> Openings(const Builder& b) {
  std::vector<std::string> v;
  const auto& t = b.c.edge_tag;
  for (size_t i = 0; i < t.size(); ++i)
    if (!t[i].empty() && t[(i + t.size() - 1) % t.size()] != t[i]) v.push_back(t[i]);
  return v;
}

Params Preset(const TemplateInfo& info, const std::string& size) {
  Params p;
  for (const auto& tp : info.parameters) p[tp.name] = size == "S" ? tp.small : size == "L" ? tp.large : tp.medium;
  return p;
}

std::vector<TemplateDef> MakeDefs() {
  std::vector<TemplateDef> defs;
  auto add = [&](const std::string& name, std::string description, std::vector<TemplateParameter> params,
                 std::function<Builder(const Params&, double)> build) {
    TemplateDef d;
    d.info.name = name;
    d.info.category = name;
    d.info.description = std::move(description);
    d.info.parameters = std::move(params);
    d.build = std::move(build);
    const Builder b = d.build(Preset(d.info, "M"), 0.025);
    d.info.anchor_labels = Labels(b);
    d.info.openings = Openings(b);
    defs.push_back(std::move(d));
  };
  add("long_sleeve_shirt", "long-sleeve shirt / sweater laid flat, sleeves angled down", ShirtParams(true),
      [](const Params& p, double h) { return Shirt(p, h, true); });
  add("tshirt", "short-sleeve T-shirt laid flat", ShirtParams(false),
      [](const Params& p, double h) { return Shirt(p, h, false); });
  add("pants", "long trousers / jeans laid flat", TrouserParams(false),
      [](const Params& p, double h) { return Trousers(p, h, false); });
  add("shorts", "short trousers laid flat", TrouserParams(true),
      [](const Params& p, double h) { return Trousers(p, h, true); });
  add("skirt", "A-line skirt laid flat",
      {{"waist_width", "flat width of the waistband", 0.34, 0.36, 0.39},
       {"hip_width", "flat width at the hip line", 0.44, 0.47, 0.50},
       {"hip_depth", "waist to hip line", 0.17, 0.18, 0.19},
       {"hem_width", "flat width at the hem", 0.56, 0.60, 0.64},
       {"length", "waist to hem", 0.50, 0.55, 0.60}},
      Skirt);
  add("towel", "rectangular towel (two layers stitched all round; no openings)",
      {{"width", "short side", 0.30, 0.50, 0.60}, {"length", "long side", 0.50, 0.90, 1.10}}, Towel);
  return defs;
}

const std::vector<TemplateDef>& Defs() {
  static const std::vector<TemplateDef> defs = MakeDefs();
  return defs;
}

const TemplateDef& FindDef(const std::string& name) {
  for (const auto& d : Defs())
    if (d.info.name == name) return d;
  std::string known;
  for (const auto& d : Defs()) known += (known.empty() ? "" : ", ") + d.info.name;
  throw Error("unknown garment template '" + name + "' (known: " + known + ")");
}

std::string Hex8(uint64_t x) {
  std::ostringstream os;
  os << std::hex << std::setw(8) << std::setfill('0') << (x & 0xffffffffULL);
  return os.str();
}

}  // namespace

const std::vector<TemplateInfo>& Templates() {
  static const std::vector<TemplateInfo> infos = [] {
    std::vector<TemplateInfo> v;
    for (const auto& d : Defs()) v.push_back(d.info);
    return v;
  }();
  return infos;
}

const TemplateInfo* FindTemplate(const std::string& name) {
  for (const auto& t : Templates())
    if (t.name == name) return &t;
  return nullptr;
}

void TemplateOptions::Validate() const {
  if (size != "S" && size != "M" && size != "L") BadField(size, "size", "must be S, M or L, got '" + size + "'");
  if (!(edge_length >= 0.005 && edge_length <= 0.2))
    BadField(edge_length, "edge_length", "must be in [0.005, 0.2] m, got " + FormatNumber(edge_length));
  if (!(layer_gap >= 0 && layer_gap <= 0.05))
    BadField(layer_gap, "layer_gap", "must be in [0, 0.05] m, got " + FormatNumber(layer_gap));
  if (!(perturbation >= 0 && perturbation <= 0.3))
    BadField(perturbation, "perturbation", "must be in [0, 0.3], got " + FormatNumber(perturbation));
  for (const auto& [k, v] : params)
    if (!std::isfinite(v) || v < 0 || v > 1e6)
      BadField(v, "parameter " + k, "must be a finite number in [0, 1e6], got " + FormatNumber(v));
}

TemplateShape MakeTemplateShape(const std::string& name, const TemplateOptions& options) {
  options.Validate();
  const TemplateDef& def = FindDef(name);
  Params p = Preset(def.info, options.size);
  std::string instance = name + "-" + options.size;
  if (options.seed != 0) {
    // Parameters perturbed in declaration order from one stream: deterministic.
    Rng rng(DeriveSeed(options.seed, name));
    for (const auto& tp : def.info.parameters)
      p[tp.name] *= 1.0 + rng.Uniform(-options.perturbation, options.perturbation);
    instance += "-s" + std::to_string(options.seed);
  }
  if (!options.params.empty()) {
    std::string key;
    for (const auto& [k, v] : options.params) {
      if (!p.count(k)) {
        std::string known;
        for (const auto& tp : def.info.parameters) known += (known.empty() ? "" : ", ") + tp.name;
        throw Error("template " + name + " has no parameter '" + k + "' (known: " + known + ")");
      }
      p[k] = v;
      std::ostringstream os;
      os << std::setprecision(17) << k << "=" << v << ";";
      key += os.str();
    }
    instance += "-p" + Hex8(DeriveSeed(0, key));
  }
  TemplateShape shape;
  shape.name = name;
  shape.instance = instance;
  shape.params = p;
  try {
    Builder b = def.build(p, options.edge_length);
    shape.contour = std::move(b.c);
    shape.anchors = std::move(b.anchors);
  } catch (const Error& e) {
    throw Error("template " + instance + ": " + e.what());
  }
  return shape;
}

Garment MakeGarment(const std::string& name, const TemplateOptions& options, MeshStats* stats) {
  const TemplateShape shape = MakeTemplateShape(name, options);
  ContourOptions co;
  co.edge_length = options.edge_length;
  co.layer_gap = options.layer_gap;
  try {
    return GarmentFromContour(shape.contour, shape.anchors, co, FindDef(name).info.category, shape.instance, stats);
  } catch (const Error& e) {
    throw Error("template " + shape.instance + ": " + e.what());
  }
}

}  // namespace drape
