#pragma once
// The one element pipeline that layout mode (measure.cpp) and chart mode
// (chart_measure.cpp) both feed. Each mode only says, per element, what it
// is and where: an ElementJob. The pipeline samples, fits, grades and
// orders the elements the same way for both (grading rules:
// element_grading.h, docs/CONVENTIONS.md "Element statuses").
//
// An ElementJob holds:
// - `element`: group, element, orientation, lp_per_mm and px_per_bar set;
// - one or more placements, each a map from the element's plane to pixels
//   (a TargetView through pose and lens, or a chart pattern's own frame),
//   the ideal artwork of that plane (the element's bars and its
//   neighbours) and the strip across the bars. The first placement is the
//   preferred one; a later one replaces it only when the profile model
//   fits it better (chart mode: the detected centre when the correlation
//   centring moved it);
// - how to sample, whether the ideal is complemented (light bars on a dark
//   ground: 1 - S(u)), and an optional `prepare` step before the final fit.
//
// Lifetime: the planes and artworks a placement points to must outlive the
// calls below.

#include <vector>

#include <opencv2/core/mat.hpp>

#include "tactres/camera/image_io.h"
#include "tactres/camera/plane_map.h"
#include "tactres/measure/element_grading.h"
#include "tactres/measure/measurement.h"
#include "tactres/profiles/profile_sampler.h"
#include "tactres/targets/coverage.h"

namespace tactres {

struct ElementPlacement {
  const PlaneToImage* plane = nullptr;
  const IndexedArtwork* artwork = nullptr;
  Strip strip;
};

struct ElementJob {
  ElementResult element;
  std::vector<ElementPlacement> placements;  // at least one
  ProfileSamplingOptions sampling;
  bool complement_ideal = false;
  ProfilePrepare prepare;
};

// One placement's profile: the strip sampled through its plane, the ideal
// from its artwork (complemented when `complement_ideal`).
SampledProfile sample_placement(const cv::Mat& luminance, const ElementPlacement& placement,
                                const ProfileSamplingOptions& sampling, bool complement_ideal, double clip_level);

// Every placement of every job: result[j][k] is job j's placement k.
std::vector<std::vector<SampledProfile>> sample_jobs(const cv::Mat& luminance, const std::vector<ElementJob>& jobs,
                                                     double clip_level);

struct GradingContext {
  const ReferenceResult& reference;  // signature and the level step per orientation
  const MeasureOptions& options;
  bool model_mismatch = false;       // a global mismatch (wrong encoding): no element is called aliased
  // Chart photographs: an ok element with one flat gap is not resolved
  // (element_grading.h, grade_element's read_gap_dips).
  bool read_gap_dips = false;
  // The strips whose noise models give every element its per-pixel noise
  // (the CNR). Null: the coarse ok strips among the jobs, as always; a live
  // frame that fits only the elements near the limit passes coarse strips
  // it sampled anyway, since its jobs may hold none.
  const std::vector<const SampledProfile*>* noise_pool = nullptr;
  // The capture's code rounding (camera/image_io.h): no element's noise is
  // taken below it.
  CodeRounding rounding{};
};

// Whether a job's placement graded `alt` replaces the one graded `r`: the
// one the model fits better (lower reduced chi^2; an unfitted one, chi^2
// 0, never wins). A model-free reading (ElementResult::m_from_dips)
// carries the chi^2 of a fit that could not measure m, so chi^2 cannot
// rank it finely against a fit that did: an ok fit wins over it unless its
// chi^2 is over 4 times the model-free placement's and its m below the
// model-free m (the fit then sits off the bars), and it wins over any
// other grade. Between two fits whose gaps both have a model-free reading
// (ElementResult::dips_m), one reading more than 3 combined sigma above
// the other's wins whatever the chi^2: it is on the bars.
bool placement_replaces(const ElementResult& alt, const ElementResult& r);

// Grades every job from its sampled placements (sample_jobs) into
// `elements`, in job order, warm-starting each orientation's fit from the
// previous good one (jobs run coarse to fine). An orientation whose level
// step is not usable is graded low_signal with a note. Returns the seconds
// spent fitting. `graded_placement`, when given, receives per job the index
// of the placement it was graded on.
double grade_jobs(const std::vector<ElementJob>& jobs, const std::vector<std::vector<SampledProfile>>& profiles,
                  const GradingContext& context, std::vector<ElementResult>& elements,
                  std::vector<size_t>* graded_placement = nullptr);

}  // namespace tactres
