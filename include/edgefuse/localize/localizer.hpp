// Object localisation for bin picking on the fused surface.
//
// Model-based: point pair feature voting (Drost et al., CVPR 2010) on a subsampled scene, pose
// clustering, point-to-plane ICP against the full scene, verification by the share of the visible
// model surface the scene supports and by free-space violations (model surface where the TSDF
// knows the space is empty). Model-free: bin removed, region growing that joins neighbours across
// smooth or convex connections, with the band along concave creases cut out first and attached
// afterwards (so stacked boxes split at their concave contact even where normals blend across it).
//
// Memory: models are sampled once at start-up into fixed tables; localising touches only the
// static buffers below (no allocation). Results are deterministic (no random sampling; the bin
// plane search uses a fixed-seed generator; sorts break ties by index).
// Numbers: float in every build (poses and votes need the dynamic range; the ARM targets have
// hardware float).
#pragma once

#include <cstddef>
#include <cstdint>

#include "edgefuse/core/status.hpp"
#include "edgefuse/localize/localize_types.hpp"
#include "edgefuse/memory/capacities.hpp"
#include "edgefuse/tsdf/extract.hpp"
#include "edgefuse/tsdf/volume.hpp"

namespace edgefuse {

//! Views of the localisation regions of the static memory map (see memmap.hpp).
struct LocalizeBuffers {
  ModelInfo* models = nullptr;          //!< models_max
  OrientedPoint* model_points = nullptr;  //!< models_max * model_points_max (dense samples)
  OrientedPoint* ppf_points = nullptr;    //!< models_max * ppf_points_max (sparse samples)
  PpfEntry* ppf_entries = nullptr;        //!< models_max * ppf_points_max * (ppf_points_max - 1)
  uint32_t* ppf_buckets = nullptr;        //!< models_max * (kPpfBuckets + 1)
  ScenePoint* scene = nullptr;            //!< scene_points_max
  uint64_t* scratch = nullptr;            //!< 2 * scene_points_max (sort keys; model sampling)
  uint32_t* grid_index = nullptr;         //!< scene_points_max
  uint32_t* grid_buckets = nullptr;       //!< kGridBuckets + 1
  //! kGridBuckets bits: bucket h's bit is set when a cell hashed to h has a scene point in it or in
  //! one of its 26 neighbours, so a clear bit ends a one-ring nearest query without its 27 lookups
  uint64_t* grid_near = nullptr;
  //! scene_points_max: the scene positions in grid_index order, so that a cell's candidates are
  //! read from contiguous memory (grid_points[e] == scene[grid_index[e]].p)
  Vec3f* grid_points = nullptr;
  uint32_t* sample = nullptr;             //!< scene_points_max
  int32_t* labels = nullptr;              //!< scene_points_max
  uint32_t* queue = nullptr;              //!< scene_points_max
  uint16_t* votes = nullptr;              //!< kVoteAccumulators * ppf_points_max * kPpfAngleBins
  PoseCandidate* candidates = nullptr;    //!< hypotheses_max vote peaks
  LocalizedObject* verified = nullptr;    //!< models_max * kClustersPerModel refined hypotheses
  LocalizedObject* results = nullptr;     //!< objects_max
  int models_max = 0;
  uint32_t model_points_max = 0;
  uint32_t ppf_points_max = 0;
  uint32_t scene_points_max = 0;
  uint32_t hypotheses_max = 0;
  int objects_max = 0;
};

struct LocalizeParams {
  float ppf_step_rel = 0.04f;    //!< PPF sampling / distance step as a share of the diameter
  int ref_stride = 2;            //!< every n-th subsampled scene point is a reference point
  int min_references = 300;      //!< ... but every one when that would give fewer references
  float cluster_trans_rel = 0.1f;  //!< pose clustering: translation within this share of the diameter
  float cluster_rot_deg = 15.0f;   //!< ... and rotation within this angle
  int icp_iterations = 12;        //!< per hypothesis (12: same bin_rig_a median error as 20, 8 is worse)
  float support_tol_m = 0.003f;    //!< a model point is supported by a scene point this close
  //! Model surface seen at a larger incidence angle (normal vs the direction to the viewpoint) is
  //! not expected in the scene: depth cameras return nothing at grazing incidence (structured light
  //! beyond ~75 deg). Such samples neither pull ICP nor count as visible-but-missing in the score.
  float max_incidence_deg = 75.0f;
  float min_score = 0.3f;          //!< least supported share of the visible model surface
  int min_support = 40;            //!< least number of supported model samples
  float free_space_margin_m = 0.004f;  //!< TSDF distance in front of the surface that counts as empty
  float max_free_space = 0.1f;     //!< most model samples allowed in known free space
  float max_overlap = 0.3f;        //!< most of a hypothesis' support already claimed by a better one
  int max_per_model = 16;          //!< top-K per model
  // Rest-pose hypotheses (second round on the scene surface no accepted pose explains): a part on
  // the floor rests on one of its stable faces, so its pose is x, y and yaw; searched by a 2D
  // Hough vote of model and scene points of equal height above the floor. Needs no normals, so it
  // finds parts whose visible surface is too thin for point pair features (an upright plate's edge).
  bool rest_poses = true;          //!< run the second round (needs a floor: bin detected or configured)
  float rest_cell_m = 0.003f;      //!< translation vote cell and scene sampling step
  float rest_height_tol_m = 0.003f;  //!< model and scene point heights match within this
  int rest_yaw_steps = 36;         //!< yaw resolution (36: 10 deg, ICP takes the rest: on bin_rig_a the same poses as 72 within 0.02 mm, 13 ms less)
  int rest_hypotheses = 6;         //!< vote peaks (after clustering) refined and verified per model
  //! Results scoring less are rechecked: their surface is searched once more for rest poses of
  //! every model, and they are accepted again only if no hypothesis there explains it better.
  //! A part the point pairs missed can otherwise be claimed by another model fitted onto part of
  //! it (bin_rig_a's tracked map after a 1e-7 m raycast change: box 3 in the bin's corner taken by
  //! a bracket at score 0.87, while the box at its rest pose explains all of it).
  float recheck_score = 0.95f;
  // bin / floor
  float floor_tol_m = 0.004f;      //!< points this close to the floor (or below it) are the bin
  float wall_tol_m = 0.004f;       //!< points this close to a wall (or outside) are the bin
  float wall_min_share = 0.02f;    //!< a wall holds at least this share of the scene points
  bool detect_walls = true;
  bool crop_to_floor = true;       //!< remove everything beyond the floor's extent (bin rims, outside)
  // model-free segmentation
  float segment_radius_m = 0.005f;   //!< neighbour distance for region growing
  float segment_smooth_deg = 15.0f;  //!< neighbours with normals closer than this always join
  float segment_concave_tol = 0.05f; //!< (n_j - n_i).(p_j - p_i)/|p_j - p_i| above -tol joins (convex)
  int segment_min_points = 150;      //!< smaller segments are noise (label 0)
  int segment_colour_tol = 0;        //!< > 0: neighbours whose colours differ by more (sum of |dR|+|dG|+|dB|) do not join
  //! Concave creases (a box on a box, a can on a tin): points with a neighbour within
  //! segment_crease_radius_m whose normal is turned by more than segment_crease_deg in a concave
  //! sense ((n_j - n_i).(p_j - p_i) < -segment_crease_concave |p_j - p_i|) are kept out of the region
  //! growing and attached afterwards to the segment they continue smoothly. 0 deg: off.
  float segment_crease_deg = 30.0f;
  //! Neighbourhood of the crease test = the band's half-width; must exceed segment_radius_m clearly (the
  //! band's two unmarked sides are about 1.4 x this apart, minus noise): on mOSD 5 mm merged a stack again.
  float segment_crease_radius_m = 0.007f;
  float segment_crease_concave = 0.3f;     //!< concavity of a crease pair (right angle: 1 .. 1.41)
  int segment_crease_min_pairs = 4;        //!< a crease point has at least this many crease pairs ...
  float segment_crease_share = 0.15f;      //!< ... and this share of its neighbours in them
  //! Pieces smaller than segment_min_points join the reported segment they touch (closest point)
  //! instead of being dropped.
  bool segment_merge_small = true;
};

//! A parallel-for supplied by the caller (src/ has no threads): runs body(context, i) once for every
//! i in [0, count), on any threads, and returns when all have run. The localiser's bodies write
//! disjoint outputs and read shared state only, so results do not depend on how they are spread.
struct ParallelFor {
  //! \param runner `runner` below  \param count jobs  \param body the job  \param context its argument
  void (*run)(void* runner, std::size_t count, void (*body)(void* context, std::size_t i), void* context) = nullptr;
  void* runner = nullptr;  //!< e.g. the host's worker pool
};

class Localizer {
 public:
  //! Spreads the PPF voting (in kVoteAccumulators chunks of references) and the refinement and
  //! verification of pose hypotheses over the caller's threads
  //! (default: serial). Identical results for any thread count.
  //! \param pf the caller's parallel-for (run == nullptr: serial)
  void set_parallel(const ParallelFor& pf) { parallel_ = pf; }

  //! Binds the static buffers; forgets all models.
  //! \param buffers regions carved from the memory map
  Status init(const LocalizeBuffers& buffers);

  //! Start-up: samples a triangle mesh (metres, object frame, counter-clockwise faces seen from
  //! outside) into the dense and PPF tables and builds the model's hash table.
  //! \param name base name kept for the output
  //! \param vertices mesh vertices  \param vertex_count their number
  //! \param triangles vertex index triples  \param triangle_count their number
  //! \param params sampling steps
  //! \param model_index index of the new model
  //! \return kInvalidArgument for an empty/degenerate mesh, bad indices or a used vertex that is not
  //!         localizable(), kCapacityExceeded when the
  //!         board holds no more models
  Status add_model(const char* name, const Vec3f* vertices, std::size_t vertex_count, const uint32_t (*triangles)[3],
                   std::size_t triangle_count, const LocalizeParams& params, int& model_index);
  //! Start-up alternative: a model given as an oriented point cloud (e.g. a partial scan).
  //! \param name base name  \param points samples with unit normals  \param count their number
  //! \param params sampling steps  \param model_index index of the new model
  Status add_model_cloud(const char* name, const OrientedPoint* points, std::size_t count,
                         const LocalizeParams& params, int& model_index);

  int model_count() const { return model_count_; }
  const ModelInfo& model(int i) const { return b_.models[i]; }
  const OrientedPoint* model_points(int i) const {
    return b_.model_points + std::size_t(i) * b_.model_points_max;
  }

  //! Loads the scene: world points with unit normals (points that are not localizable() and
  //! non-finite normals are skipped).
  //! \param points the fused surface (or a cloud with normals)  \param count number of points
  //! \param context viewpoint (and, when known, the floor)
  //! \param volume the TSDF the points came from (free-space check), or null for a plain cloud
  //! \param grid_cell_m nearest-neighbour grid cell (about 2-3 point spacings; at least
  //!        kLocalizeGridCellMinM, else kInvalidArgument)
  Status set_scene(const SurfacePoint* points, std::size_t count, const SceneContext& context,
                   const TsdfVolume* volume, float grid_cell_m);
  //! As set_scene for ScenePoints that already carry their source index.
  Status set_scene_points(const ScenePoint* points, std::size_t count, const SceneContext& context,
                          const TsdfVolume* volume, float grid_cell_m);

  //! Finds the bin (dominant plane = floor, plus walls perpendicular to it on the floor's
  //! boundary) and removes its points from the scene. Updates the context.
  Status remove_bin(const LocalizeParams& params);

  //! The bin from configuration instead of detection: sets the floor (up = the bin's z axis) and
  //! its four walls and removes their points exactly as remove_bin() does. Updates the context.
  //! \param bin floor pose and inner size (kInvalidArgument when the size is not positive or the
  //!        pose is not finite)
  //! \param params floor_tol_m / wall_tol_m: points this close to the floor / a wall are the bin
  Status set_bin(const BinGeometry& bin, const LocalizeParams& params);

  //! Model-based localisation with every loaded model.
  //! \param params matching and verification settings
  //! \param max_results at most this many results (<= objects_max)
  //! \param count results written, in picking order
  Status localize(const LocalizeParams& params, int max_results, std::size_t& count);

  //! Model-free segmentation of the scene (after remove_bin).
  //! \param params segmentation settings
  //! \param max_results at most this many segments (<= objects_max), in picking order
  //! \param count results written
  Status segment(const LocalizeParams& params, int max_results, std::size_t& count);

  const LocalizedObject* results() const { return b_.results; }
  //! Scene points after bin removal and their segment labels (after segment(); 0 = none).
  std::size_t scene_count() const { return scene_count_; }
  const ScenePoint* scene() const { return b_.scene; }
  const int32_t* labels() const { return b_.labels; }
  const SceneContext& context() const { return ctx_; }

  //! Diagnostics: verifies model m at a given pose (e.g. the true one), optionally after ICP from it,
  //! exactly as localize() verifies its hypotheses; says why a known object is missed.
  //! \param m model index  \param T pose to check (T_world_object)
  //! \param params verification settings  \param refine_first run ICP from T first
  //! \param out verification result (out.T_world_object = the refined pose)
  //! \return false when ICP found too few correspondences
  bool check_pose(int m, const Pose& T, const LocalizeParams& params, bool refine_first, LocalizedObject& out) const;

  //! Pose candidates of the last localize() before verification (for diagnostics).
  std::size_t last_candidates() const { return last_candidates_; }

 private:
  Status build_ppf_table(int m, const LocalizeParams& params);
  Status finish_model(const char* name, std::size_t dense, const LocalizeParams& params, int& model_index);
  void build_grid(float cell_m);
  //! set_scene and set_scene_points: keeps point_at(i) for i < count where localizable, then
  //! builds the grid (defined in scene.cpp, the only place that instantiates it).
  template <class PointAt>
  Status load_scene(std::size_t count, PointAt point_at, const SceneContext& context, const TsdfVolume* volume,
                    float grid_cell_m);
  //! Nearest scene point within radius (index or -1).
  int32_t nearest(const Vec3f& q, float radius_m, float& dist2) const;
  //! Sets grid_near's bits from the grid (build_grid's last step).
  void mark_near_cells();
  //! Labels every unlabelled scene point within radius of q (claims of an accepted hypothesis).
  void for_each_within(const Vec3f& q, float radius_m, int32_t label) const;
  //! Claims the scene points on the visible surface of model m at T.
  void claim(int m, const Pose& T, const LocalizeParams& params, int32_t label) const;
  std::size_t subsample_scene(float step_m);
  //! Breadth-first: appends to queue[tail..) every scene point connected to seed through neighbours
  //! within radius that is not yet visited (marking it); returns the new tail.
  std::size_t grow_component(std::size_t seed, float radius_m, uint32_t* visited, std::size_t tail) const;
  //! Removes the scene points on/below the floor, on/outside a wall, or beyond the floor's extent
  //! (all from ctx_), then rebuilds the grid.
  void remove_bin_points(const LocalizeParams& params);
  //! Labels the scene's connected parts (neighbours within radius) into labels[].
  void connected_components(float radius_m);
  //! segment(): labels concave-crease points -1 (labels[] zero on entry).
  void mark_creases(const LocalizeParams& params);
  static constexpr std::size_t kCreaseChunks = 8;  //!< mark_creases jobs (fixed: same labels for any thread count)
  static void crease_job(void* self, std::size_t chunk);
  //! segment(): region growing from every point labelled 0; new labels follow `label`; returns the last.
  int32_t grow_regions(const LocalizeParams& params, int32_t label);
  //! segment(): crease points (-1) join the neighbouring segment they continue smoothly.
  void attach_creases(const LocalizeParams& params);
  //! segment(): members of each label contiguous in queue[]; sample[l] = end of label l's run.
  void sort_by_label(std::size_t labels_n);
  //! segment(): small pieces join a touching large segment (after sort_by_label); true if any did.
  bool merge_small_segments(const LocalizeParams& params, std::size_t labels_n);
  //! segment(): labels every scene point (creases, region growing); returns the last label.
  int32_t label_segments(const LocalizeParams& params);
  //! segment(): caps `label` to the arrays, sorts by label, merges small pieces; returns the label count.
  std::size_t group_by_label(const LocalizeParams& params, int32_t& label);
  //! segment(): centre and box axes (columns of B) of the segment queue[start, tail).
  void segment_box_frame(std::size_t start, std::size_t tail, Vec3f& centre, Mat3f& B) const;
  //! segment(): the segment queue[start, tail) as a result: box, top, grasp point and approach.
  LocalizedObject describe_segment(std::size_t start, std::size_t tail, int32_t seg_label) const;
  //! segment(): keeps o among the first max_results results in picking order (appended while there
  //! is room, else in place of the last one if o comes before it).
  void keep_in_picking_order(const LocalizedObject& o, int max_results, std::size_t& count) const;
  //! segment(): labels[] and the results' segment become picking ranks (1 = first; 0: not reported).
  void label_by_picking_rank(int32_t label, std::size_t count);
  std::size_t vote_model(int m, const LocalizeParams& params, std::size_t first_candidate);
  //! Votes of reference sample r of model m into accumulator `votes`; false when no peak.
  bool vote_reference(int m, std::size_t r, std::size_t ns, uint16_t* votes, PoseCandidate& out) const;
  static void vote_job(void* self, std::size_t chunk);
  bool refine(int m, Pose& T, const LocalizeParams& params) const;
  // Replaces verified hypothesis h of model m by a half-turned twin of it that explains the scene
  // better (nearly symmetric shapes), if one does; true when it did.
  bool try_flipped_twins(int m, const LocalizeParams& params, LocalizedObject& h) const;
  //! The three half-turn twins of one hypothesis, refined and verified by twin_job.
  struct TwinBatch {
    const Localizer* me;
    int m;
    const LocalizeParams* params;
    Pose first;                  //!< the hypothesis the twins are turned from
    bool refined[3];             //!< per axis: refine() converged
    LocalizedObject twin[3];     //!< per axis: the verified twin (when refined)
  };
  //! \param context a TwinBatch  \param axis object axis of the half turn (0..2)
  static void twin_job(void* context, std::size_t axis);
  // True when a verified hypothesis is good enough to keep (score, support, free space).
  static bool passes_thresholds(const LocalizedObject& h, const LocalizeParams& params);
  bool plausible(int m, const Pose& T, const LocalizeParams& params) const;
  void verify(int m, const Pose& T, const LocalizeParams& params, LocalizedObject& out, int claim_label,
              float* overlap) const;
  float free_space_at(const Vec3f& p) const;
  //! True when model surface at q with normal n faces the viewpoint within the incidence angle
  //! whose cosine is given (cos of params.max_incidence_deg, computed once per caller).
  bool observable(const Vec3f& q, const Vec3f& n, float cos_max_incidence) const;
  void sort_picking_order(std::size_t count) const;
  //! The recheck round (LocalizeParams::recheck_score): takes the weak results out of
  //! results[0, count) (the first kRecheckMax in acceptance order), searches only their surface
  //! for rest poses and accepts the best explanations among those hypotheses and the weak results.
  void recheck_weak_results(const LocalizeParams& params, int max_results, std::size_t& count, int* per_model);
  static constexpr std::size_t kRecheckMax = 8;  //!< weak results rechecked per localisation
  //! Models whose accepted results are counted against LocalizeParams::max_per_model (the length
  //! of localize()'s per-model counts; results of models beyond it are not limited).
  static constexpr int kPerModelCounted = 64;
  //! Slots of LocalizeBuffers::verified (hypotheses refined and verified in one round).
  std::size_t verified_capacity() const { return std::size_t(b_.models_max) * kClustersPerModel; }
  //! Sorts the refined hypotheses verified[0, n) best first and appends those not mostly claimed by
  //! a better one to the results (claiming their surface), up to max_results.
  void accept_hypotheses(std::size_t n, const LocalizeParams& params, int max_results, std::size_t& count,
                         int* per_model) const;
  //! Refines and verifies verified[0, n) over the caller's threads; returns the accepted, compacted.
  std::size_t refine_all(std::size_t n, const LocalizeParams& params);
  // Rest-pose hypotheses (rest_pose.cpp).
  //! Start-up: the model's stable resting faces (flat, extreme, centroid above the contact patch).
  void find_rest_faces(int m);
  //! Samples the unclaimed scene (labels == 0) at the vote cell, sorted by height above the floor.
  bool prepare_rest_scene(const LocalizeParams& params);
  //! Votes x, y, yaw of model m on each resting face; queues the best peaks into verified[first..).
  std::size_t queue_rest_hypotheses(int m, const LocalizeParams& params, std::size_t first);
  static void rest_vote_job(void* self, std::size_t chunk);
  struct RestVoter;  //!< rest_vote_job's chunk (rest_pose.cpp)
  //! Visible samples of model m at T with an unclaimed scene point near them: count x share (0 when
  //! the share is too small for ICP + verification to accept the pose).
  float rest_coverage(int m, const Pose& T, const LocalizeParams& params) const;
  static constexpr int kRestHeightBins = 512;
  struct RestScene {
    Vec3f a0, a1;            //!< floor-plane axes (with ctx_.up: right-handed)
    std::size_t count = 0;   //!< packed samples (x, y, height) in scratch, sorted by height bin
    float bin_m = 0.003f;    //!< height bin
    float lo[2] = {0, 0}, hi[2] = {0, 0};  //!< extent of the samples in the floor axes
    uint32_t bins[kRestHeightBins + 1] = {};  //!< first sample of each height bin
    // per model (set before a vote batch)
    float cell_m = 0.003f, origin[2] = {0, 0};
    int w = 0, h = 0;        //!< vote grid
    int faces = 0, yaw_steps = 0;
  };
  RestScene rest_;

  LocalizeBuffers b_;
  int model_count_ = 0;
  std::size_t scene_count_ = 0;
  SceneContext ctx_;
  const TsdfVolume* volume_ = nullptr;
  float grid_cell_m_ = 0.005f;
  float grid_inv_ = 200.0f;
  std::size_t last_candidates_ = 0;
  ParallelFor parallel_;
  const LocalizeParams* job_params_ = nullptr;  //!< of the running refine_job / vote_job batch
  int job_model_ = 0;            //!< vote_job: model, subsampled scene size, references, first slot
  std::size_t job_ns_ = 0, job_refs_ = 0, job_first_ = 0, job_stride_ = 1;
  static void refine_job(void* self, std::size_t k);
};

//! Normals of an organised cloud from its image neighbours (central differences, oriented towards
//! the camera at the origin); points without valid neighbours get NaN normals.
//! \param points width x height camera-frame points (NaN = invalid)
//! \param width  \param height organisation
//! \param max_jump_m neighbours farther than this (depth discontinuity) are not used
//! \param normals output, width x height
void organised_normals(const Vec3f* points, int width, int height, float max_jump_m, Vec3f* normals);

}  // namespace edgefuse
