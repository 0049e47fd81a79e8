#include "tactres/measure/measurement_io.h"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "tactres/util/csv.h"

namespace tactres {
namespace {

// JSON numbers must be finite: anything else becomes null.
nlohmann::json finite(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// The level step's plane over the target (gain_field.h), or "uniform".
nlohmann::json gain_field_to_json(const GainField& f) {
  if (!f.plane) return {{"model", "uniform"}};
  return {{"model", "plane"},
          {"origin_mm", {finite(f.origin_mm.x), finite(f.origin_mm.y)}},
          {"contrast", finite(f.contrast)},
          {"contrast_sigma", finite(std::sqrt(f.covariance[0]))},
          {"gradient_per_mm", {finite(f.gradient_x_per_mm), finite(f.gradient_y_per_mm)}},
          {"gradient_sigma_per_mm", {finite(std::sqrt(f.covariance[3])), finite(std::sqrt(f.covariance[5]))}},
          {"samples", f.samples},
          {"chi2_reduced", finite(f.chi2_reduced)},
          {"spread", finite(f.spread)}};
}

}  // namespace

nlohmann::json measurement_to_json(const Measurement& m, const MeasurementContext& ctx) {
  nlohmann::json j;
  j["schema"] = kMeasurementSchema;
  j["tactres_version"] = ctx.tactres_version;
  j["image"] = ctx.image;
  j["design"] = ctx.design;
  j["layout"] = ctx.layout;
  // The layout's identity, whatever path it was given by (tactres report
  // compares measurements made from different working directories).
  if (!ctx.layout_sha1.empty()) j["layout_sha1"] = ctx.layout_sha1;
  j["usable"] = m.usable;
  j["problem"] = m.problem.empty() ? nlohmann::json() : nlohmann::json(m.problem);
  if (ctx.options) {
    j["criterion"] = {{"threshold", ctx.options->criterion.threshold},
                      {"significance_z", ctx.options->criterion.significance_z},
                      {"detectability_k", ctx.options->detectability.k}};
    j["preset"] = to_string(ctx.options->preset);
  }
  if (ctx.loaded) {
    // The measurement's own decision wins: a guessed curve may have been
    // replaced by one the reference patch fits far better.
    const TransferDecision& transfer = m.transfer.reason.empty() ? ctx.loaded->transfer : m.transfer;
    j["input"] = {{"width", ctx.loaded->width},
                  {"height", ctx.loaded->height},
                  {"channels", ctx.loaded->channels},
                  {"pixel_format", ctx.loaded->pixel_format},
                  {"bits_per_sample", ctx.loaded->bits_per_sample},
                  {"transfer", transfer.curve.name()},
                  {"transfer_reason", transfer.reason},
                  {"non_finite_pixels", ctx.loaded->non_finite_pixels},
                  {"orientation", ctx.loaded->orientation},
                  {"turned_upright", ctx.loaded->turned_upright}};
  }
  if (m.transfer_check.checked)
    j["transfer_check"] = {{"applied", m.transfer_check.applied},
                           {"best", m.transfer_check.best},
                           {"chi2_applied", finite(m.transfer_check.chi2_applied)},
                           {"chi2_best", finite(m.transfer_check.chi2_best)},
                           {"mismatch", m.transfer_check.mismatch},
                           {"switched", m.transfer_check.switch_to.has_value()}};
  j["warnings"] = m.warnings;
  j["camera"] = {{"model", m.camera_source.empty() ? nlohmann::json(nullptr) : nlohmann::json(m.camera_source)},
                 {"distortion_corrected", m.distortion_corrected}};
  if (m.pose.usable) {
    nlohmann::json rt = nlohmann::json::array();
    for (double v : m.pose.rt_camera_from_target_mm) rt.push_back(finite(v));
    j["pose"] = {{"rt_camera_from_target", rt},
                 {"seen_from_behind", m.pose.seen_from_behind},
                 {"reprojection_rms_px", finite(m.pose.rms_px)},
                 {"fiducials_used", m.pose.observed_disc_indices.size()}};
  } else {
    j["pose"] = nullptr;
  }
  if (m.reference.usable)
    j["reference"] = {{"signature", m.reference.signature == Signature::albedo ? "albedo" : "shading"},
                      {"contrast_x", finite(m.reference.vertical_bars.contrast)},
                      {"contrast_x_sigma", finite(m.reference.vertical_bars.contrast_sigma)},
                      {"contrast_y", finite(m.reference.horizontal_bars.contrast)},
                      {"contrast_y_sigma", finite(m.reference.horizontal_bars.contrast_sigma)},
                      {"chi2_x", finite(m.reference.vertical_bars.chi2_reduced)},
                      {"chi2_y", finite(m.reference.horizontal_bars.chi2_reduced)}};
  else
    j["reference"] = nullptr;
  // Only when the light varies over the target: a uniform field is the
  // patch's step, already above.
  if (m.reference.usable && (m.reference.horizontal_field.plane || m.reference.vertical_field.plane))
    j["reference"]["gain_field"] = {{"horizontal_bars", gain_field_to_json(m.reference.horizontal_field)},
                                    {"vertical_bars", gain_field_to_json(m.reference.vertical_field)}};
  // Null where the capture was never measured (0 would read as a limit).
  const auto positive = [](double v) { return v > 0 ? finite(v) : nlohmann::json(nullptr); };
  j["nyquist_lp_per_mm"] = {{"horizontal_bars", positive(m.nyquist_h_lp_per_mm)},
                            {"vertical_bars", positive(m.nyquist_v_lp_per_mm)}};
  const DetectabilityCriterion rose = ctx.options ? ctx.options->detectability : DetectabilityCriterion{};
  j["limits"] = {{"horizontal_bars", breakdown_to_json(m.horizontal_parts, rose)},
                 {"vertical_bars", breakdown_to_json(m.vertical_parts, rose)}};
  nlohmann::json els = nlohmann::json::array();
  for (const ElementResult& e : m.elements) {
    const bool ok = e.status == ElementStatus::ok;
    nlohmann::json center = nullptr;
    if (e.outline_valid) {
      const Vec2 c = e.strip_center_px();
      center = {finite(std::round(100 * c.x) / 100), finite(std::round(100 * c.y) / 100)};
    }
    els.push_back({{"group", e.group},
                   {"element", e.element},
                   {"orientation", to_string(e.orientation)},
                   {"lp_per_mm", finite(e.lp_per_mm)},
                   {"px_per_bar", finite(e.px_per_bar)},
                   {"center_px", center},
                   {"m", ok ? finite(e.m) : nlohmann::json()},
                   {"m_sigma", ok ? finite(e.m_sigma) : nlohmann::json()},
                   {"m_source", ok ? nlohmann::json(e.m_from_dips ? "gap_dips" : "fit") : nlohmann::json()},
                   {"m_dips", ok && e.dips_m_sigma > 0 ? finite(e.dips_m) : nlohmann::json()},
                   {"m_dips_sigma", ok && e.dips_m_sigma > 0 ? finite(e.dips_m_sigma) : nlohmann::json()},
                   {"psf_shape_beta", ok && !e.m_from_dips ? finite(e.beta) : nlohmann::json()},
                   {"chi2_reduced", e.chi2_reduced > 0 ? finite(e.chi2_reduced) : nlohmann::json()},
                   {"status", to_string(e.status)},
                   {"resolved", e.resolved},
                   {"signal", ok ? finite(e.signal) : nlohmann::json()},
                   {"noise_sd", ok ? finite(e.noise_sd) : nlohmann::json()},
                   {"pixels_per_bar", ok ? finite(e.bar_pixels) : nlohmann::json()},
                   {"cnr", ok ? finite(e.cnr) : nlohmann::json()},
                   {"cnr_sigma", ok ? finite(e.cnr_sigma) : nlohmann::json()},
                   {"detectable", e.detectable},
                   {"note", e.note.empty() ? nlohmann::json() : nlohmann::json(e.note)}});
  }
  j["elements"] = els;
  nlohmann::json timing = nlohmann::json::object();
  timing["decode"] = finite(ctx.decode_seconds);
  for (const auto& [stage, s] : m.stage_seconds) timing[stage] = finite(s);
  j["timing_seconds"] = timing;
  if (ctx.chart) j["chart"] = chart_to_json(*ctx.chart);
  return j;
}

std::string measurement_csv_header() {
  return "image,design,group,element,orientation,lp_per_mm,px_per_bar,m,m_sigma,status,resolved,cnr,cnr_sigma,"
         "detectable,indices\n";
}

std::string measurement_csv_rows(const Measurement& m, const MeasurementContext& ctx) {
  std::string out;
  // A chart whose group is unknown: group, element and lp_per_mm are
  // relative to the largest element found (as the JSON's chart.indices says).
  const char* indices = ctx.chart && ctx.chart->anchor == ChartAnchor::none ? "relative" : "absolute";
  for (const ElementResult& e : m.elements) {
    const bool ok = e.status == ElementStatus::ok;
    out += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n", csv_cell(ctx.image), csv_cell(ctx.design),
                       e.group, e.element, to_string(e.orientation), csv_number(e.lp_per_mm, 4),
                       csv_number(e.px_per_bar, 3), ok ? csv_number(e.m, 5) : "", ok ? csv_number(e.m_sigma, 5) : "",
                       to_string(e.status), e.resolved ? "true" : "false", ok ? csv_number(e.cnr, 4) : "",
                       ok ? csv_number(e.cnr_sigma, 4) : "", e.detectable ? "true" : "false", indices);
  }
  return out;
}

nlohmann::json chart_to_json(const ChartDetection& d) {
  nlohmann::json j;
  j["mode"] = "usaf1951";
  j["found"] = d.found;
  j["polarity"] = d.light_bars ? "light_bars_on_dark" : "dark_bars_on_light";
  j["anchor"] = to_string(d.anchor);
  j["anchor_description"] = d.anchor_description;
  j["indices"] = d.anchor == ChartAnchor::none ? "relative" : "absolute";
  j["patterns_found"] = d.patterns.size();
  // The rows' pitch of a fibre bundle's honeycomb over the image, or null.
  j["fibre_lattice_pitch_px"] =
      d.fibre_lattice_pitch_px > 0 ? nlohmann::json(d.fibre_lattice_pitch_px) : nlohmann::json();
  // Found (binarised) elements, and apart from them those placed by their
  // column or the nesting of the pairs (measured the same way).
  // An element of which one pattern was found and the other placed beside
  // it counts as found; the placed pattern is listed apart.
  nlohmann::json placed = nlohmann::json::array(), partners = nlohmann::json::array(),
                 joined = nlohmann::json::array();
  for (const ChartElement& e : d.elements) {
    if (e.partner_joined) joined.push_back({{"group", e.group}, {"element", e.element}});
    if (partner_placed(d, e))
      partners.push_back({{"group", e.group}, {"element", e.element},
                          {"placed", d.patterns[e.h].predicted ? "horizontal_bars" : "vertical_bars"}});
    else if (!found_in_image(d, e))
      placed.push_back({{"group", e.group}, {"element", e.element}});
  }
  j["elements_found"] = d.elements.size() - placed.size();
  j["partners_placed"] = partners;
  // Elements whose two patterns were found apart and joined by place
  // (ChartElement::partner_joined).
  j["partners_joined"] = joined;
  j["unpaired_patterns"] = d.unpaired_patterns;
  j["hv_period_ratio"] = d.hv_period_ratio;  // 1 face on; a chart seen obliquely is foreshortened
  j["single_pattern"] = d.single_pattern;  // one triplet in view, measured in the image's orientation
  j["predicted_elements"] = d.predicted_elements;
  j["placed_elements"] = placed;
  const auto& a = d.arrangement;
  if (a.steps_checked > 0 || !a.note.empty())
    j["arrangement"] = {{"recognised", a.recognised},
                        {"mirrored", a.recognised ? nlohmann::json(a.mirrored) : nlohmann::json()},
                        {"steps_checked", a.steps_checked},
                        {"steps_matched", a.steps_matched},
                        {"group_labels_read", a.labels_read},
                        {"note", a.note}};
  j["partial_elements"] = nlohmann::json::array();
  for (const ChartElement& e : d.partial)
    j["partial_elements"].push_back(
          {{"group", e.group},
           {"element", e.element},
           {"found", e.h >= 0 ? "horizontal_bars" : "vertical_bars"},
           {"status", e.partial == ChartElement::Partial::partner_out_of_view ? "out_of_view" : "fit_failed"},
           {"reason", e.partial_reason}});
  if (const ChartElement* largest = largest_found(d))
    j["largest_element"] = {{"group", largest->group}, {"element", largest->element}, {"period_px", largest->period_px}};
  return j;
}

}  // namespace tactres
