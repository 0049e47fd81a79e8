// The standard arrangement of a USAF-1951 chart (chart_detect.h, "What the
// arrangement can and cannot tell"): the steps between the elements found
// and the elements a column predicts. The generated chart's group labels
// are read in chart_segment_labels.cpp.

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "chart_detect_internal.h"
#include "tactres/targets/mil_std_chart.h"

namespace tactres::locate_detail {

namespace {

// Where index n (modulo 12) stands in a pair of groups (chart_detect.h):
// 1..5 are the even group's elements 2..6 down the left column, 6..11 the
// odd group's elements 1..6 down the right column, 0 the even group's
// element 1 at the lower right.
int column_of(int n) {
  const int m = mod12(n);
  return m == 0 ? 0 : m <= 5 ? 1 : 2;
}

// Whether absolute indices na and nb (modulo 12 as column_of takes them,
// na / 12 the pair of groups) stand in one column: an even group's element
// 1 (column 0) stands alone.
bool same_column(int na, int nb) {
  return floor_div(na, 12) == floor_div(nb, 12) && column_of(na) != 0 && column_of(na) == column_of(nb);
}

}  // namespace

int h_side(int n, bool generated_style) { return generated_style || column_of(n) == 1 ? 1 : -1; }

// Phase (index of relative index 0, modulo 12) and handedness from the
// topology of the arrangement, which every maker keeps while the spacings
// differ between them (a column step is 6.5 bar widths on one real chart
// and 8 on another, 7.5 on the generated one):
// - two found elements of one column, up to 5 indices apart, stand one
//   below the other, 5-10 bar widths a step; any other two are not so;
// - each element's H triplet stands on the side h_side says, as seen with
//   the column running down (a mirror swaps the sides).
// Every hypothesis (phase, mirror, which way is down, maker's style) is
// scored by how many of these observations it explains; the best wins when
// it explains nearly all and clearly more than any other phase or
// handedness. When several come that close, they are the `ways` it may
// fit (see the header).
void recognise_arrangement(ChartDetection& D, const ScaleField& field,
                           std::vector<ChartDetection::Arrangement>* ways) {
  if (ways) ways->clear();
  auto& A = D.arrangement;
  const std::vector<ChartElement>& E = D.elements;
  if (E.size() < 2) {
    A.note = "arrangement not recognised: fewer than two elements with both triplets found on their own "
             "(it is read from whole elements)";
    return;
  }
  // The chart's y axis: across the H triplets' bars (one sign for all).
  const Vec2 y_axis = perp(D.patterns[E.front().h].bar_dir);
  std::vector<int> side;  // +1: H left of V with y_axis down, unmirrored
  for (const ChartElement& e : E) {
    const Vec2 hv = D.patterns[e.v].center_px - D.patterns[e.h].center_px;
    side.push_back(hv.x * y_axis.y - hv.y * y_axis.x > 0 ? 1 : -1);
  }
  // Column steps as seen: for each pair i < j at most 5 indices apart, the
  // signed distance along y_axis in units of the bar widths stepped over.
  struct Step {
    size_t i, j;
    double along_w;  // > 0: j below i along +y_axis
    bool straight;   // little sideways motion
  };
  std::vector<Step> steps;
  for (size_t i = 0; i < E.size(); ++i)
    for (size_t j = i + 1; j < E.size(); ++j) {
      const int dk = E[j].relative_index - E[i].relative_index;
      if (dk < 1 || dk > 5) continue;
      double sum_w = 0;
      for (int k = 0; k < dk; ++k) sum_w += field.bar_px(D, E[i]) * std::exp2(-k / 6.0);
      const Vec2 d = D.patterns[E[j].h].center_px - D.patterns[E[i].h].center_px;
      const double along = dot(d, y_axis), across = dot(d, perp(y_axis));
      steps.push_back({i, j, along / sum_w, std::abs(across) < 0.3 * std::abs(along)});
    }
  struct Hyp {
    int phase = 0;
    bool mirrored = false;
    int matched = 0;
    bool generated = false;
    int down = 1;
  };
  std::vector<Hyp> best_per;  // the best of each (phase, mirror)
  const int checked = static_cast<int>(E.size() + steps.size());
  for (int p = 0; p < 12; ++p)
    for (bool mirrored : {false, true}) {
      Hyp h{p, mirrored, -1};
      for (int down : {1, -1})
        for (bool generated : {false, true}) {
          int matched = 0;
          for (size_t i = 0; i < E.size(); ++i)
            matched += side[i] * down * (mirrored ? -1 : 1) == h_side(E[i].relative_index + p, generated);
          for (const Step& s : steps) {
            const int na = E[s.i].relative_index + p, nb = E[s.j].relative_index + p;
            const double along = down * s.along_w;
            matched += same_column(na, nb) == (s.straight && along >= 5 && along <= 10);
          }
          if (matched > h.matched) h.matched = matched, h.generated = generated, h.down = down;
        }
      best_per.push_back(h);
    }
  std::sort(best_per.begin(), best_per.end(), [](const Hyp& a, const Hyp& b) { return a.matched > b.matched; });
  const Hyp& best = best_per.front();
  const int runner_up = best_per[1].matched;
  A.steps_checked = checked;
  A.steps_matched = best.matched;
  if (E.size() < 4 || best.matched < checked - std::max(1, checked / 10)) {
    A.note = fmt::format("arrangement not recognised: {} of {} observations (element sides and column steps) fit "
                         "the standard arrangement at best",
                         best.matched, checked);
    return;
  }
  const auto as_arrangement = [&](const Hyp& h) {
    ChartDetection::Arrangement way = A;
    way.recognised = true;
    way.candidate_phases.clear();  // a way is one of them
    way.phase = h.phase;
    way.mirrored = h.mirrored;
    way.generated_style = h.generated;
    way.down_px = double(h.down) * y_axis;
    way.steps_matched = h.matched;
    return way;
  };
  if (best.matched - runner_up < 3) {
    A.note = fmt::format("arrangement not recognised: the elements found fit it in more than one way ({} and {} "
                         "of {} observations); too little of the chart is in view",
                         best.matched, runner_up, checked);
    // Every way that makes it ambiguous (within 3 observations of the
    // best): its phase, and the way, so that the numbers are read under
    // each of them.
    for (const Hyp& h : best_per)
      if (best.matched - h.matched < 3) {
        A.candidate_phases.push_back(h.phase);
        if (ways) ways->push_back(as_arrangement(h));
      }
    if (!ways) return;
    if (ways->size() > kMaxArrangementWays) ways->clear();
    return;
  }
  A = as_arrangement(best);
}

// See ChartDetection::predicted_elements.
void predict_column_ends(ChartDetection& D) {
  const double r = std::exp2(-1.0 / 6);
  std::map<int, size_t> by_index;
  for (size_t i = 0; i < D.elements.size(); ++i) by_index[D.elements[i].relative_index] = i;
  std::vector<ChartElement> added;
  // Element numbers are known when anchored, and also when only the
  // arrangement is recognised (its phase fixes them and the group's parity,
  // not the group): then a column ends at element 6 too. Unanchored and
  // unrecognised, one step beyond three in a row is all that is known, and
  // only where no way the arrangement may fit (candidate_phases) ends the
  // column there.
  const std::optional<int> origin = series_origin(D);
  const bool numbered = origin.has_value();
  struct Number {
    int group = 0, element = 1;
  };
  auto number = [&](const ChartElement& e) {
    if (!origin) return Number{};
    const int n = *origin + e.relative_index;
    return Number{floor_div6(n), n - 6 * floor_div6(n) + 1};
  };
  for (const auto& [k, i] : by_index) {
    if (by_index.count(k + 1) || !by_index.count(k - 1)) continue;
    const ChartElement &e1 = D.elements[by_index[k - 1]], &e2 = D.elements[i];
    const Number n1 = number(e1), n2 = number(e2);
    if (numbered && n2.element == 6) continue;  // the group's column ends here
    const Vec2 c1 = D.patterns[e1.h].center_px, c2 = D.patterns[e2.h].center_px;
    const Vec2 d12 = c2 - c1;
    if (!numbered) {
      // One column: three in a row, the second step the first shrunk by r,
      // in the same direction.
      if (!by_index.count(k - 2)) continue;
      const Vec2 c0 = D.patterns[D.elements[by_index[k - 2]].h].center_px;
      if (norm(d12 - r * (c1 - c0)) > 0.1 * norm(d12)) continue;
      // Where the arrangement fits in several ways, each must have the
      // three and the next in one column: a way that ends the column at e2
      // puts the next element elsewhere (dev_02 turned by 180 degrees: a
      // step placed below G6E6, on black ground, where the G7E1 not found
      // heads the other column).
      const auto continues = [&](int phase) {
        return same_column(e1.relative_index - 1 + phase, e2.relative_index + 1 + phase);
      };
      if (!std::all_of(D.arrangement.candidate_phases.begin(), D.arrangement.candidate_phases.end(), continues))
        continue;
    } else {
      // Two in a row are one column only when the element numbers say so:
      // an even group's element 1 stands apart, at the lower right;
      // elements 2..6, and an odd group's 1..6, are one column.
      const bool even = ((n2.group % 2) + 2) % 2 == 0;
      if (n1.group != n2.group || (even && n1.element == 1)) continue;
      // And the step is a column step: about (5 + 2.5) bar widths of e1
      // across its bars' length, i.e. along the H triplet's bars' normal.
      const double bar = 0.5 * e1.period_px;
      if (std::abs(norm(d12) / bar - (5 + mil_std::kColumnGap)) > 1.5) continue;
    }
    // Numbered: on to the group's element 6 (the finer ones are the
    // measured ones' neighbours, so they are modelled too); otherwise the
    // column's end is unknown: one step.
    const int steps = numbered ? 6 - n2.element : 1;
    ChartElement prev = e2, before = e1;
    for (int step = 0; step < steps; ++step) {
      ChartElement next = prev;
      next.relative_index = prev.relative_index + 1;
      next.period_px = prev.period_px * r;
      if (0.5 * next.period_px < kMinPredictedBarPx) break;
      if (by_index.count(next.relative_index)) break;  // found after all
      const int n = D.largest_index + next.relative_index;
      next.group = floor_div6(n);
      next.element = n - 6 * next.group + 1;
      for (int* which : {&next.h, &next.v}) {
        const bool h = which == &next.h;
        BarPattern p = D.patterns[h ? prev.h : prev.v];
        const Vec2 c = p.center_px;
        p.center_px = c + r * (c - D.patterns[h ? before.h : before.v].center_px);
        p.period_px *= r;
        p.bar_length_px *= r;
        p.predicted = true;
        p.nested = false;
        for (Vec2& b : p.bar_centers_px) b = p.center_px + r * (b - c);
        D.patterns.push_back(p);
        *which = static_cast<int>(D.patterns.size()) - 1;
      }
      added.push_back(next);
      before = prev;
      prev = next;
    }
  }
  D.predicted_elements += static_cast<int>(added.size());
  for (const ChartElement& e : added) D.elements.push_back(e);
  sort_by_index(D.elements);
}

namespace {

// The nesting (chart_detect_internal.h, fit_nesting): 12 indices, 1/4 the size.
constexpr int kPairIndices = 12;
constexpr double kPairScale = 0.25;

// Where a coarse pattern's point lands nested about centre_px.
Vec2 nested_point(Vec2 p_px, Vec2 centre_px) { return centre_px + kPairScale * (p_px - centre_px); }

BarPattern nested_pattern(const BarPattern& p, Vec2 centre_px) {
  BarPattern q = p;
  q.center_px = nested_point(p.center_px, centre_px);
  q.period_px *= kPairScale;
  q.bar_length_px *= kPairScale;
  for (Vec2& b : q.bar_centers_px) b = nested_point(b, centre_px);
  q.predicted = true;
  q.nested = true;
  return q;
}

// Whether `fine` lies where `coarse` nests about centre_px: both patterns
// within a quarter of its period of the coarse ones' nested images, and
// never less than kNestingPlaceErrorPx, a small blurred pattern's own
// error of place: in dev_04 turned by 5 degrees G6E4 and G6E6 (periods 5.6
// and 4.6 px) lie 2.1 px off the nested images about the point they give
// together, and group 7 went unpredicted.
constexpr double kNestingPlaceErrorPx = 2.5;
// How far `fine`'s patterns lie from where `coarse`'s nest about centre_px
// (the larger of the two distances; a partial fine element's one found).
double nesting_miss_px(const ChartDetection& D, const ChartElement& fine, const ChartElement& coarse, Vec2 centre_px) {
  const auto miss = [&](int f, int c) {
    return f < 0 ? 0.0 : norm(nested_point(D.patterns[c].center_px, centre_px) - D.patterns[f].center_px);
  };
  return std::max(miss(fine.h, coarse.h), miss(fine.v, coarse.v));
}

bool nests(const ChartDetection& D, const ChartElement& fine, const ChartElement& coarse, Vec2 centre_px) {
  return nesting_miss_px(D, fine, coarse, centre_px) <= std::max(0.25 * fine.period_px, kNestingPlaceErrorPx);
}

// The centre that element `fine` and the coarse one give: the mean of what
// its found patterns give (fine = c + (coarse - c) / 4).
Vec2 centre_from(const ChartDetection& D, const ChartElement& fine, const ChartElement& coarse) {
  const auto one = [&](int f, int c) {
    return (1 / (1 - kPairScale)) * (D.patterns[f].center_px - kPairScale * D.patterns[c].center_px);
  };
  if (fine.h < 0 || fine.v < 0) return fine.h < 0 ? one(fine.v, coarse.v) : one(fine.h, coarse.h);
  return 0.5 * (one(fine.h, coarse.h) + one(fine.v, coarse.v));
}

// The patterns an element shows (two, or one when partial).
int patterns_shown(const ChartElement& e) { return (e.h >= 0) + (e.v >= 0); }

// The index offsets a fine element may be off by: a well-sampled one's
// period is trusted (0 only); a finer one's may be a step off (blur). A
// lone triplet (`may_move` false) nests as indexed or not at all: its
// index is the series' again afterwards, never the nesting's.
std::vector<int> offsets_for(const ChartElement& e, bool may_move) {
  return !may_move || e.period_px >= kWellSampledPeriodPx ? std::vector<int>{0} : std::vector<int>{0, -1, 1};
}

// Which index offset makes element `fine` nest about centre_px against the
// coarse element 12 indices (less the offset) coarser, or nullopt.
std::optional<int> nesting_offset(const ChartDetection& D, const std::vector<ChartElement>& E,
                                  const std::map<int, size_t>& coarse, size_t fine, Vec2 centre_px, bool may_move) {
  const ChartElement& f = E[fine];
  for (int delta : offsets_for(f, may_move)) {
    const auto c = coarse.find(f.relative_index + delta - kPairIndices);
    if (c != coarse.end() && nests(D, f, E[c->second], centre_px)) return delta;
  }
  return std::nullopt;
}

// Moves each element's index by its offset, all at once, keeping the
// indices unique: a move onto an index another element ends up holding is
// dropped (and so, in turn, any move that needed that one out of the way).
void reindex(std::vector<ChartElement>& E, const std::vector<std::pair<size_t, int>>& offsets) {
  std::vector<int> target(E.size());
  for (size_t i = 0; i < E.size(); ++i) target[i] = E[i].relative_index;
  for (const auto& [j, delta] : offsets) target[j] += delta;
  for (bool changed = true; changed;) {
    changed = false;
    std::map<int, int> holders;
    for (int t : target) ++holders[t];
    for (size_t i = 0; i < E.size(); ++i)
      if (target[i] != E[i].relative_index && holders[target[i]] > 1) {
        target[i] = E[i].relative_index;
        changed = true;
      }
  }
  for (size_t i = 0; i < E.size(); ++i) E[i].relative_index = target[i];
  sort_by_index(E);
}

// The elements that nest about one point, each with its index offset;
// the point they give together; how many moved; and how far, in all, they
// lie from their nested images about that point.
struct Nesting {
  std::vector<std::pair<size_t, int>> inliers;
  int patterns = 0;  // the inliers' patterns found
  Vec2 point_px{0, 0};
  int moves = 0;
  double miss_px = 0;
};

// More patterns nest; among as many, fewer index moves (the periods are
// believed where the places allow it: in dev_04 turned by 20 degrees the
// inner pair's first two elements nest as found, and as well each moved
// one index finer, about another point where no group 7 element is); then
// the closer fit.
bool better_nesting(const Nesting& a, const Nesting& b) {
  if (a.patterns != b.patterns) return a.patterns > b.patterns;
  if (a.moves != b.moves) return a.moves < b.moves;
  return a.miss_px < b.miss_px;
}

}  // namespace

std::optional<Vec2> fit_nesting(const ChartDetection& D, std::vector<ChartElement>& kept,
                                const std::vector<ChartElement>& partial) {
  // The complete elements first, so that an inlier below kept.size() is one of them.
  std::vector<ChartElement> E = kept;
  E.insert(E.end(), partial.begin(), partial.end());
  std::map<int, size_t> coarse;  // well-sampled complete elements by index: their indices are trusted
  for (size_t i = 0; i < kept.size(); ++i)
    if (E[i].period_px >= kWellSampledPeriodPx) coarse[E[i].relative_index] = i;
  // The elements that nest about a point, and the point they give
  // together; the point most patterns nest about wins.
  const auto inliers_about = [&](Vec2 point_px) {
    std::vector<std::pair<size_t, int>> inliers;
    for (size_t j = 0; j < E.size(); ++j)
      if (const auto d = nesting_offset(D, E, coarse, j, point_px, j < kept.size())) inliers.push_back({j, *d});
    return inliers;
  };
  const auto mean_centre = [&](const std::vector<std::pair<size_t, int>>& inliers) {
    Vec2 sum{0, 0};
    for (const auto& [j, delta] : inliers)
      sum = sum + centre_from(D, E[j], E[coarse.at(E[j].relative_index + delta - kPairIndices)]);
    return (1.0 / double(inliers.size())) * sum;
  };
  // Candidates: the point each element gives against the coarse element
  // it may nest to, and the mean of two such points (one element's point
  // carries its own error of place), each with the elements that nest
  // about it and then about the point those give together.
  std::vector<std::pair<size_t, int>> singles;  // (element, index offset)
  for (size_t i = 0; i < E.size(); ++i)
    for (int delta : offsets_for(E[i], i < kept.size()))
      if (coarse.count(E[i].relative_index + delta - kPairIndices)) singles.push_back({i, delta});
  const auto nesting_of = [&](std::vector<std::pair<size_t, int>> inliers) {
    Nesting n;
    if (!inliers.empty()) {
      n.point_px = mean_centre(inliers);
      for (const auto& [j, delta] : inliers) {
        n.patterns += patterns_shown(E[j]);
        n.moves += delta != 0;
        n.miss_px += nesting_miss_px(D, E[j], E[coarse.at(E[j].relative_index + delta - kPairIndices)], n.point_px);
      }
    }
    n.inliers = std::move(inliers);
    return n;
  };
  // Four patterns, as two complete elements show, and one complete
  // element among them at least (lone triplets alone are no nesting, and
  // must not outrank one that is).
  const auto valid = [&](const Nesting& n) {
    return n.patterns >= 4 && std::any_of(n.inliers.begin(), n.inliers.end(),
                                           [&](const auto& in) { return in.first < kept.size(); });
  };
  Nesting best;
  for (size_t a = 0; a < singles.size(); ++a)
    for (size_t b = a; b < singles.size(); ++b) {
      if (b != a && singles[a].first == singles[b].first) continue;
      std::vector<std::pair<size_t, int>> inliers =
          inliers_about(mean_centre(a == b ? std::vector{singles[a]} : std::vector{singles[a], singles[b]}));
      if (!inliers.empty())
        if (std::vector<std::pair<size_t, int>> again = inliers_about(mean_centre(inliers));
            again.size() > inliers.size())
          inliers = std::move(again);
      if (Nesting n = nesting_of(std::move(inliers)); valid(n) && better_nesting(n, best)) best = std::move(n);
    }
  if (best.inliers.empty()) return std::nullopt;
  // The centre from all that nest; then each complete fine element takes
  // the index of the nested image it lies on (a lone triplet nested as
  // indexed: offset 0).
  std::vector<std::pair<size_t, int>> moves;
  for (const auto& in : best.inliers)
    if (in.first < kept.size()) moves.push_back(in);
  reindex(kept, moves);
  return best.point_px;
}

// See ChartDetection::predicted_elements.
void predict_nested_pairs(ChartDetection& D, Vec2 centre_px, int cols, int rows) {
  // Only into a pair of groups that shows an element found: the chart's
  // finest pair is followed by empty ground, not by another. Which pair an
  // index is in needs the element numbers (pairs start at an even group's
  // element 1, n = 0 modulo 12).
  const std::optional<int> origin = series_origin(D);
  if (!origin) return;
  const auto pair_of = [&](int k) { return floor_div(*origin + k, kPairIndices); };
  std::vector<ChartElement> all = D.elements;  // coarse to fine, so that a prediction can predict the next pair
  std::map<int, size_t> held;
  std::set<int> pairs_found;
  for (size_t i = 0; i < all.size(); ++i) {
    held[all[i].relative_index] = i;
    if (found_in_image(D, all[i])) pairs_found.insert(pair_of(all[i].relative_index));
  }
  int added = 0;
  for (size_t i = 0; i < all.size(); ++i) {
    const ChartElement coarse = all[i];
    if (held.count(coarse.relative_index + kPairIndices)) continue;
    ChartElement e = coarse;
    e.relative_index += kPairIndices;
    if (!pairs_found.count(pair_of(e.relative_index))) continue;
    e.period_px *= kPairScale;
    e.group += 2;
    if (0.5 * e.period_px < kMinPredictedBarPx) continue;
    const BarPattern h = nested_pattern(D.patterns[coarse.h], centre_px),
                     v = nested_pattern(D.patterns[coarse.v], centre_px);
    const auto inside = [&](const BarPattern& p) {
      const double r = p.bar_length_px;
      return p.center_px.x >= r && p.center_px.y >= r && p.center_px.x <= cols - 1 - r && p.center_px.y <= rows - 1 - r;
    };
    if (!inside(h) || !inside(v)) continue;
    D.patterns.push_back(h);
    e.h = static_cast<int>(D.patterns.size()) - 1;
    D.patterns.push_back(v);
    e.v = static_cast<int>(D.patterns.size()) - 1;
    held[e.relative_index] = all.size();
    all.push_back(e);
    ++added;
  }
  D.predicted_elements += added;
  D.elements = std::move(all);
  sort_by_index(D.elements);
}

}  // namespace tactres::locate_detail
