#include "generator/recipe/keys.h"

#include <cstdio>
#include <sstream>

namespace drape {
namespace recipe_keys {

const std::vector<OptionKey<Recipe>>& TopKeys() {
  static const std::vector<OptionKey<Recipe>> t = {
      {"name",
       {},
       "name",
       "required; release name (letters, digits, `_`, `-`); default output `datasets/<name>/<version>/`"},
      {"version",
       {},
       "MAJOR.MINOR.PATCH",
       "required; TFDS meaning: PATCH same records, MINOR added fields, MAJOR records/splits changed"},
      {"seed", {}, "integer ≥ 0", "required; every random number of the build derives from it and the job key"},
      {"description", Ref(&Recipe::description), "string", "free text for the dataset card"},
      {"license", Ref(&Recipe::license), "string", "Hugging Face license id"},
      {"allow_outside_paths", Ref(&Recipe::allow_outside_paths), "bool",
       "allow file paths outside the recipe's folder"},
      {"materials", {}, "mapping", "custom materials (presets are always available by name)"},
      {"garments", {}, "list", "required; what to hang (non-empty)"},
      {"simulation", {}, "mapping", "hanging options"},
      {"sensing", {}, "mapping", "sweep options per kind of split (`database`, `sensed`)"},
      {"fusion", {}, "mapping", "TSDF options"},
      {"feature", {}, "mapping", "feature size"},
      {"splits", {}, "mapping", "which instances go where (default: everything in train)"},
  };
  return t;
}

const std::vector<OptionKey<Material>>& MaterialKeys() {
  static const std::vector<OptionKey<Material>> t = {
      {"preset", {}, "name", "start from this preset's values"},
      {"stretch_percent", Ref(&Material::stretch_percent), "%",
       "measured stretch: (L1−L2)/L2 × 100 hung from an extremum vs flat"},
      {"friction_deg", Ref(&Material::friction_deg), "degrees", "tilt angle at which the garment starts to slide"},
      {"area_density", Ref(&Material::area_density), "kg/m²", "mass per area of one layer"},
      {"bending", Ref(&Material::bending_stiffness), "—",
       "bending stiffness relative to stretch stiffness (generator/hang/material.h); unused with `bending_rigidity`"},
      {"bending_rigidity", Ref(&Material::bending_rigidity), "N·m",
       "bending rigidity B of one layer, [0, 0.01]; > 0: hinge bending (docs/fabric.md) replaces `bending`"},
      {"crease_yield", Ref(&Material::crease_yield), "1/m",
       "curvature beyond which a fold's rest angle yields (creases), [0, 1e5]; 0: never"},
      {"crease_weakening", Ref(&Material::crease_weakening), "—",
       "a yielded fold's stiffness ÷ (1 + this × damage), [0, 100]"},
      {"crease_recovery", Ref(&Material::crease_recovery_deg), "degrees",
       "measured crease recovery angle (AATCC 66), [0, 180); > 0: the yield is fitted to it (docs/fabric.md)"},
  };
  return t;
}

const std::vector<OptionKey<GarmentSpec>>& GarmentKeys() {
  using G = GarmentSpec;
  using T = TemplateOptions;
  static const std::vector<OptionKey<G>> t = {
      {"name", {}, "name", "unique garment name used in job keys (default: template name or file stem)"},
      {"template",
       {},
       "name",
       "`long_sleeve_shirt`, `tshirt`, `pants`, `shorts`, `skirt`, `towel` (exactly one of `template`/`file`)",
       "templates"},
      {"file", {}, "path", "mesh file (any format assimp reads), relative to the recipe's folder", "imports"},
      {"anchors_file", {}, "path", "the `NAME.anchors.json` sidecar with labelled anchors", "imports"},
      {"unit_scale", Ref(&G::unit_scale), "m per file unit", "file units → metres (e.g. 0.01 for centimetres)",
       "imports"},
      {"category", {}, "string", "category recorded for the garment (default `custom`)", "imports"},
      {"size", Ref(&G::options, &T::size), "`S`, `M`, `L`", "preset proportions", "templates"},
      {"params",
       {},
       "mapping",
       "exact template parameters in metres/radians (e.g. towel `width`, `length`); names as in garments/templates.cpp",
       "templates"},
      {"edge_length", Ref(&G::options, &T::edge_length), "m", "target mesh edge length", "templates"},
      {"layer_gap", Ref(&G::options, &T::layer_gap), "m", "distance between front and back layer", "templates"},
      {"perturbation", Ref(&G::options, &T::perturbation), "fraction",
       "relative random variation of every parameter per instance", "templates"},
      {"instances", Ref(&G::instances), "count",
       "seeded instances; instance k's shape seed is DeriveSeed(seed, \"NAME/i<k>\")"},
      {"materials", {}, "list", "required, non-empty; material names (variants)"},
      {"anchors", {}, "`all` or list", "anchor labels to hang from (default `all`; see garments/anchors.md)"},
  };
  return t;
}

const std::vector<OptionKey<HangOptions>>& SimulationKeys() {
  using H = HangOptions;
  static const std::vector<OptionKey<H>> t = {
      {"time_step", Ref(&H::time_step), "s", "Bullet step (1/60 does not settle)"},
      {"solver_iterations", Ref(&H::solver_iterations), "count", "Bullet position iterations"},
      {"damping", Ref(&H::damping), "fraction per step", "Bullet kDP: node velocity removed per step"},
      {"self_collision", Ref(&H::self_collision), "bool",
       "the collision handler after every step (off only to measure its cost: no guarantee)"},
      {"layer_thickness", Ref(&H::layer_thickness), "m",
       "vertex–face and edge–edge pairs closer than this are repelled (with repulsion)"},
      {"repulsion", Ref(&H::repulsion), "bool",
       "proximity repulsion in the collision handler (off: CCD and impact zones alone keep the mesh intersection-free, "
       "layers touch)"},
      {"strain_limit", Ref(&H::strain_limit), "× stretch",
       "edges clamped to (1 + strain_limit × the material's stretch) × rest length"},
      {"settle.distance", Ref(&H::settle_distance), "m", "settled when no node moved more than this ..."},
      {"settle.window", Ref(&H::settle_window), "s", "... over this window"},
      {"min_time", Ref(&H::min_time), "s", "simulated time before settling may be declared"},
      {"time_cap", Ref(&H::time_cap), "s", "not settled by then → retried with a smaller step, then failed"},
      {"jaw_width", Ref(&H::jaw_width), "m",
       "gripper pad size: the nodes inside the jaw (pads × opening) at the grasp point are held"},
      {"jaw_opening", Ref(&H::jaw_opening), "m", "gripper opening across the layers"},
  };
  return t;
}

const std::vector<OptionKey<SensingSpec>>& SensingKeys() {
  using S = SensingSpec;
  using W = SweepOptions;
  using K = KinectOptions;
  using I = Intrinsics;
  static const std::vector<OptionKey<S>> t = {
      {"frames", Ref(&S::sweep, &W::frames), "count", "depth frames per sweep (both directions with back_and_forth)"},
      {"degrees", Ref(&S::sweep, &W::degrees), "degrees", "turn of the gripper (one way)"},
      {"back_and_forth", Ref(&S::sweep, &W::back_and_forth), "bool",
       "turn one way then back (the unfolding set-up, ~550 frames)"},
      {"noise", Ref(&S::sweep, &W::kinect, &K::noise), "bool",
       "Kinect v1 noise model (axial, lateral, quantisation, dropouts); default true for `sensed`"},
      {"keep_frames", Ref(&S::keep_frames), "bool",
       "store `sweep/` (16-bit PNG depth in mm + cameras.json) in the entries"},
      {"scene", Ref(&S::sweep, &W::scene), "bool", "gripper, arm, table, wall and floor in view"},
      {"camera.height", Ref(&S::sweep, &W::camera_height), "m", "camera height (see generator/sweep/sweep.h)"},
      {"camera.distance", Ref(&S::sweep, &W::camera_distance), "m", "horizontal distance camera → turning axis"},
      {"camera.gripper_height", Ref(&S::sweep, &W::gripper_height), "m", "world height of the grasp point"},
      {"camera.look_at_height", Ref(&S::sweep, &W::look_at_height), "m",
       "where the optical axis crosses the turning axis"},
      {"camera.image_width", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::width), "px", "image width"},
      {"camera.image_height", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::height), "px", "image height"},
      {"camera.fx", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::fx), "px", "focal length, x"},
      {"camera.fy", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::fy), "px", "focal length, y"},
      {"camera.cx", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::cx), "px", "principal point, x"},
      {"camera.cy", Ref(&S::sweep, &W::kinect, &K::intrinsics, &I::cy), "px", "principal point, y"},
      {"camera.min_range", Ref(&S::sweep, &W::kinect, &K::min_range), "m", "nearer readings are \"no data\""},
      {"camera.max_range", Ref(&S::sweep, &W::kinect, &K::max_range), "m", "farther readings are \"no data\""},
  };
  return t;
}

const std::vector<OptionKey<FusionOptions>>& FusionKeys() {
  using F = FusionOptions;
  static const std::vector<OptionKey<F>> t = {
      {"voxels_per_metre", Ref(&F::voxels_per_metre), "1/m", "TSDF voxel density (paper: 384)"},
      {"truncation", Ref(&F::truncation), "m", "truncation distance (0 = 4 voxels)"},
      {"box",
       {},
       "`{min: [x,y,z], max: [x,y,z]}`",
       "segmentation box, object frame (grasp at origin, y up); default in generator/fusion/fusion.h"},
      {"pose_noise_degrees", Ref(&F::pose_noise_degrees), "degrees", "simulated gripper-encoder error per frame"},
      {"frames_stride", Ref(&F::frames_stride), "count", "fuse every k-th frame"},
      {"carve_min_views", Ref(&F::carve_min_views), "count", "views needed to carve a block as free space"},
  };
  return t;
}

const std::vector<OptionKey<FeatureOptions>>& FeatureKeys() {
  using F = FeatureOptions;
  static const std::vector<OptionKey<F>> t = {
      {"layers", Ref(&F::layers), "count", "N, layers along the vertical axis"},
      {"rings", Ref(&F::rings), "count", "R, rings around it"},
      {"sectors", Ref(&F::sectors), "count", "Φ, angular sectors (≤ 64); the feature has N·R·Φ bits"},
      {"origin", Ref(&F::origin), "`top_layer` or `grip`",
       "polar axis: mean (x, z) of the top layer's points (Algorithm 1) or the gripper's axis"},
  };
  return t;
}

const std::vector<OptionKey<SplitSpec>>& SplitKeys() {
  static const std::vector<OptionKey<SplitSpec>> t = {
      {"garments", {}, "list", "required; selectors (below)"},
      {"sensing", {}, "`database` or `sensed`", "defaults: train → database, others → sensed"},
      {"perturbation", {}, "mapping", "perturbations of this split (below)"},
      {"repeats", Ref(&SplitSpec::repeats), "count", "perturbed repetitions per anchor (keys get `/p<r>`)"},
      {"unperturbed", Ref(&SplitSpec::unperturbed), "bool",
       "also one unperturbed job per anchor (key without `/p<r>`, hung as in a split without perturbation), before its "
       "repeats"},
      {"hangs_per_anchor", Ref(&SplitSpec::hangs_per_anchor), "count",
       "K hangs per anchor sharing its label: hang 0 as with K = 1, hangs 1..K−1 keyed `/h<k>` with their own seed and "
       "`hang_variation`"},
      {"hang_variation.grasp_miss", Ref(&SplitSpec::hang_variation, &HangVariation::grasp_miss), "m",
       "hangs 1..K−1: σ per axis of a Gaussian grasp miss on the flat pattern"},
      {"hang_variation.material_jitter", Ref(&SplitSpec::hang_variation, &HangVariation::material_jitter), "fraction",
       "hangs 1..K−1: each of the material's four values × (1 + U(−j, j)), per hang (stiffness refitted)"},
      {"hang_variation.pickup_spin", Ref(&SplitSpec::hang_variation, &HangVariation::pickup_spin), "rad/s",
       "hangs 1..K−1: the flat garment starts turning about the grasp point, each axis U(−w, w) (a lift's swing)"},
      {"miss_curve",
       {},
       "list of m",
       "`test` only: grasp misses (whole mm, ascending); each adds a split `test_miss_<mm>mm` "
       "(the test split with the grasp that far from the anchor, one direction per anchor at every level)"},
  };
  return t;
}

const std::vector<OptionKey<SplitSelector>>& SelectorKeys() {
  static const std::vector<OptionKey<SplitSelector>> t = {
      {"garment", {}, "name", "required; a garment's `name`"},
      {"instances", {}, "`all` or list", "instance indices, from 0 (default `all`)"},
      {"materials", {}, "list", "narrows the garment's materials (default: all)"},
      {"anchors", {}, "`all` or list", "narrows the garment's anchors (default `all`)"},
      {"max_anchors", Ref(&SplitSelector::max_anchors), "count",
       "> 0: a seeded sample of this many anchors per instance"},
  };
  return t;
}

const std::vector<OptionKey<Perturbation>>& PerturbationKeys() {
  static const std::vector<OptionKey<Perturbation>> t = {
      {"grasp_offset", Ref(&Perturbation::grasp_offset), "m",
       "grasp point moved this far from the anchor on the flat pattern, random direction per job"},
      {"grasp_miss", Ref(&Perturbation::grasp_miss), "m",
       "σ per axis of a Gaussian grasp miss on the flat pattern, drawn per job (a robot's grasp; not with "
       "`grasp_offset`)"},
      {"size_scale",
       {},
       "factor or `[min, max]`",
       "each instance scaled uniformly by a factor drawn once per instance (default 1)"},
      {"material_jitter", Ref(&Perturbation::material_jitter), "fraction",
       "each of the material's four values × (1 + U(−j, j)), drawn once per instance and material"},
      {"turn", Ref(&Perturbation::turn), "bool",
       "the hung garment turned about the gripper by a seeded angle U(0, 360°) before the sweep"},
      {"gripper_pose_noise", Ref(&Perturbation::gripper_pose_noise), "degrees",
       "σ of the turning gripper's encoder error per frame (the fusion's pose noise)"},
  };
  return t;
}

}  // namespace recipe_keys

std::vector<RecipeSectionDoc> RecipeKeyDocs() {
  using namespace recipe_keys;
  Recipe recipe;
  GarmentSpec garment;
  HangOptions hang;
  SensingSpec sensing = DatabaseSensingDefaults();
  FusionOptions fusion;
  FeatureOptions feature;
  SplitSpec split;
  SplitSelector selector;
  Perturbation perturbation;
  return {KeysDoc("top level", TopKeys(), &recipe),
          KeysDoc("materials", MaterialKeys(), static_cast<Material*>(nullptr)),
          KeysDoc("garments", GarmentKeys(), &garment),
          KeysDoc("simulation", SimulationKeys(), &hang),
          KeysDoc("sensing", SensingKeys(), &sensing),
          KeysDoc("fusion", FusionKeys(), &fusion),
          KeysDoc("feature", FeatureKeys(), &feature),
          KeysDoc("splits", SplitKeys(), &split),
          KeysDoc("splits garments", SelectorKeys(), &selector),
          KeysDoc("perturbation", PerturbationKeys(), &perturbation)};
}

std::string RecipeKeysMarkdown(const RecipeSectionDoc& section) { return KeysMarkdown(section); }

}  // namespace drape
