#include "generator/recipe/jobs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "common/error.h"
#include "common/rng.h"
#include "garments/io.h"
#include "garments/templates.h"

namespace drape {

uint64_t InstanceSeed(const Recipe& recipe, const std::string& garment, int instance) {
  const uint64_t s = DeriveSeed(recipe.seed, garment + "/i" + std::to_string(instance));
  return s == 0 ? 1 : s;
}

Garment MakeJobGarment(const Recipe& recipe, const Job& job) {
  const GarmentSpec& g = recipe.garments.at(job.garment);
  Garment out;
  if (!g.template_name.empty()) {
    TemplateOptions o = g.options;
    o.seed = job.instance_seed;
    out = MakeGarment(g.template_name, o);
  } else {
    ImportOptions io;
    io.unit_scale = g.unit_scale;
    io.category = g.category;
    io.instance = g.name;
    out = ImportGarment(g.file, g.anchors, io);
  }
  if (job.size_scale != 1.0) {
    // Size perturbation: the whole pattern scaled about its origin.
    out.mesh.V *= job.size_scale;
    if (out.uv.rows()) out.uv *= job.size_scale;
    for (auto& a : out.anchors) {
      a.uv *= job.size_scale;
      a.position *= job.size_scale;
    }
  }
  return out;
}

HangOptions HangOptionsFor(const Recipe& recipe, const GarmentSpec& g) {
  HangOptions h = recipe.hang;
  if (!g.template_name.empty()) h.fit_edge_length = g.options.edge_length;
  return h;
}

std::string Slug(const std::string& key) {
  std::string s;
  for (char c : key) {
    const bool ok =
        (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-' || c == '.';
    s += ok ? c : '-';
  }
  return s;
}

std::vector<int> ShardJobs(int num_jobs, int k, int n) {
  if (n < 1 || k < 1 || k > n)
    throw Error("shard " + std::to_string(k) + "/" + std::to_string(n) + ": need 1 <= K <= N");
  std::vector<int> out;
  for (int i = k - 1; i < num_jobs; i += n) out.push_back(i);
  return out;
}

namespace {

// The selector's anchors (else the garment's); with max_anchors a seeded sample, kept in
// the garment's label order.
std::vector<std::string> SelectedAnchors(const Recipe& recipe, const std::string& split, const SplitSelector& sel,
                                         const GarmentSpec& g, const std::string& iname) {
  std::vector<std::string> anchors = sel.anchors.empty() ? g.anchor_labels : sel.anchors;
  if (sel.max_anchors > 0 && sel.max_anchors < static_cast<int>(anchors.size())) {
    Rng rng(DeriveSeed(recipe.seed, "select/" + split + "/" + iname));
    std::vector<int> idx(anchors.size());
    for (size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
    for (size_t i = idx.size() - 1; i > 0; --i) std::swap(idx[i], idx[rng.Below(i + 1)]);
    idx.resize(sel.max_anchors);
    std::sort(idx.begin(), idx.end());
    std::vector<std::string> picked;
    picked.reserve(idx.size());
    for (int i : idx) picked.push_back(anchors[i]);
    anchors = picked;
  }
  return anchors;
}

// `m` with its four values (stretch, friction, density, bending) × (1 + U(−j, j)) drawn
// from `seed`; the factors − 1 go to `jitter`. The bending factor scales whichever
// bending the material uses (relative links or the hinges' rigidity B).
Material Jittered(Material m, double j, uint64_t seed, double jitter[4]) {
  if (j <= 0) return m;
  Rng rng(seed);
  for (int k = 0; k < 4; ++k) jitter[k] = rng.Uniform(-j, j);
  m.stretch_percent *= 1 + jitter[0];
  m.friction_deg *= 1 + jitter[1];
  m.area_density *= 1 + jitter[2];
  m.bending_stiffness *= 1 + jitter[3];
  m.bending_rigidity *= 1 + jitter[3];
  return m;
}

// The material with its seeded relative jitter, drawn once per instance and material.
Material JitteredMaterial(const Recipe& recipe, const Perturbation& pt, const std::string& iname,
                          const std::string& mname, double jitter[4]) {
  return Jittered(recipe.materials.at(mname), pt.material_jitter,
                  DeriveSeed(recipe.seed, iname + "/" + mname + "/material_jitter"), jitter);
}

// Hang k ≥ 1 of an anchor: its own grasp miss, material jitter and pickup spin, each from
// its own seed (so setting one does not move the others' draws).
void VaryHang(const HangVariation& v, Job& j) {
  if (v.grasp_miss > 0) {
    Rng rng(DeriveSeed(j.seed, "hang_variation/grasp_miss"));
    const double dx = v.grasp_miss * rng.Normal();
    const double dy = v.grasp_miss * rng.Normal();
    j.hang_miss = Vec2(dx, dy);
    j.grasp_offset += j.hang_miss;
  }
  j.material = Jittered(j.material, v.material_jitter, DeriveSeed(j.seed, "hang_variation/material_jitter"),
                        j.hang_material_jitter);
  if (v.pickup_spin > 0) {
    Rng rng(DeriveSeed(j.seed, "hang_variation/pickup_spin"));
    for (int a = 0; a < 3; ++a) j.pickup_spin[a] = rng.Uniform(-v.pickup_spin, v.pickup_spin);
  }
}

// The split's perturbation of job j (key without the split's prefix: `base`): the
// instance's size and material jitter, its grasp (fixed distance, a miss level's or a
// drawn miss), turn and pose noise.
void Perturb(const Recipe& recipe, const SplitSpec& split, const std::string& base, double size_scale,
             const double jitter[4], Job& j) {
  const Perturbation& pt = split.perturbation;
  j.size_scale = size_scale;
  std::copy(jitter, jitter + 4, j.material_jitter);
  if (split.miss_level >= 0) {
    // The miss curve: one direction per anchor (from the key without the
    // split's prefix), the same at every level.
    const double a = 2 * M_PI * Rng(DeriveSeed(DeriveSeed(recipe.seed, base), "miss_direction")).Uniform();
    j.grasp_offset = pt.grasp_offset * Vec2(std::cos(a), std::sin(a));
  } else if (pt.grasp_offset > 0) {
    Rng rng(DeriveSeed(j.seed, "grasp_offset"));
    const double a = 2 * M_PI * rng.Uniform();
    j.grasp_offset = pt.grasp_offset * Vec2(std::cos(a), std::sin(a));
  }
  if (pt.grasp_miss > 0) {
    Rng rng(DeriveSeed(j.seed, "grasp_miss"));
    const double dx = pt.grasp_miss * rng.Normal();
    const double dy = pt.grasp_miss * rng.Normal();
    j.grasp_offset = Vec2(dx, dy);
  }
  if (pt.turn) j.turn = 2 * M_PI * Rng(DeriveSeed(j.seed, "turn")).Uniform();
  j.pose_noise_degrees = pt.gripper_pose_noise;
}

// Ids: zero-padded index (at least 5 digits) + slug of the key; keys must be unique.
void AssignIds(std::vector<Job>& jobs) {
  int width = 5;
  for (size_t n = jobs.size(); n >= 100000; n /= 10) ++width;
  std::set<std::string> keys;
  for (auto& j : jobs) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%0*d", width, j.index);
    j.id = std::string(buf) + "-" + Slug(j.key);
    DRAPE_CHECK(keys.insert(j.key).second, "duplicate job key " + j.key);
  }
}

}  // namespace

std::vector<Job> ExpandJobs(const Recipe& recipe) {
  std::vector<Job> jobs;
  for (const auto& split : recipe.splits) {
    const Perturbation& pt = split.perturbation;
    for (const auto& sel : split.selectors) {
      const GarmentSpec* g = recipe.FindGarment(sel.garment);
      DRAPE_CHECK(g != nullptr, sel.garment);
      const int gi = static_cast<int>(g - recipe.garments.data());
      const auto& materials = sel.materials.empty() ? g->materials : sel.materials;
      for (int inst : sel.instances) {
        const std::string iname = g->name + "/i" + std::to_string(inst);
        const std::vector<std::string> anchors = SelectedAnchors(recipe, split.name, sel, *g, iname);
        double size_scale = 1.0;
        if (pt.size_scale_max != pt.size_scale_min || pt.size_scale_min != 1.0) {
          Rng rng(DeriveSeed(recipe.seed, iname + "/size_scale"));
          size_scale = rng.Uniform(pt.size_scale_min, pt.size_scale_max);
        }
        for (const auto& mname : materials) {
          double jitter[4] = {0, 0, 0, 0};
          const Material m = JitteredMaterial(recipe, pt, iname, mname, jitter);
          const Material plain = recipe.materials.at(mname);
          for (const auto& anchor : anchors) {
            // rep < 0: the split's unperturbed job of this anchor (SplitSpec::unperturbed).
            for (int rep = split.unperturbed ? -1 : 0; rep < split.repeats; ++rep) {
              for (int hang = 0; hang < split.hangs_per_anchor; ++hang) {
                const bool perturbed = rep >= 0;
                Job j;
                j.index = static_cast<int>(jobs.size());
                const bool suffix = perturbed && (split.repeats > 1 || split.unperturbed);
                const std::string base = iname + "/" + mname + "/" + anchor +
                                         (suffix ? "/p" + std::to_string(rep) : "") +
                                         (hang > 0 ? "/h" + std::to_string(hang) : "");
                const bool ladder = split.name.rfind("test_", 0) == 0;
                j.key = ladder ? split.name + "/" + base : base;
                j.split = split.name;
                j.sensing = split.sensing;
                j.garment = gi;
                j.instance = inst;
                j.instance_name = iname;
                j.instance_seed = InstanceSeed(recipe, g->name, inst);
                j.material_name = mname;
                j.anchor = anchor;
                j.repeat = std::max(rep, 0);
                j.hang = hang;
                j.seed = DeriveSeed(recipe.seed, j.key);
                j.hang_seed = DeriveSeed(DeriveSeed(recipe.seed, base), "hang");
                j.material = perturbed ? m : plain;
                if (perturbed) Perturb(recipe, split, base, size_scale, jitter, j);
                if (hang > 0) VaryHang(split.hang_variation, j);
                jobs.push_back(std::move(j));
              }
            }
          }
        }
      }
    }
  }
  AssignIds(jobs);
  return jobs;
}

}  // namespace drape
