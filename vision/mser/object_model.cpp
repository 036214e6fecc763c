#include "vision/mser/object_model.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

namespace vigil::vision::mser {
namespace {

constexpr int kPairType = 1, kIndividualType = 2;

bool finite(const ModelRegion& r) {
  return std::isfinite(r.centroid.x) && std::isfinite(r.centroid.y) && std::isfinite(r.cxx) && std::isfinite(r.cyy) &&
         std::isfinite(r.cxy) && std::isfinite(r.area) && std::isfinite(r.colour[0]) && std::isfinite(r.colour[1]) &&
         std::isfinite(r.colour[2]) && std::isfinite(r.straightness);
}

// One vote: for a model, the object scale and centre one matched feature implies.
struct Vote {
  int feature;  // the query feature (pairs first, then individuals)
  int a, b;     // the model's regions
  float scale;
  cv::Point2f centre;
};

}  // namespace

ModelRegion ModelRegion::from(const Region& r, float straightness) {
  ModelRegion m;
  m.centroid = r.centroid;
  m.cxx = r.cxx;
  m.cyy = r.cyy;
  m.cxy = r.cxy;
  m.area = static_cast<float>(r.size);
  m.colour = r.mean;
  m.straightness = straightness;
  return m;
}

float compare_value(double a, double b) {
  if (!(a > 0) || !(b > 0)) return a == b ? 0.0f : (a < b ? 1.0f : -1.0f);
  return static_cast<float>(a < b ? 1 - a / b : -(1 - b / a));
}

double diameter_along(const ModelRegion& r, cv::Point2f u) {
  const double ux = u.x, uy = u.y;
  const double det = static_cast<double>(r.cxx) * r.cyy - static_cast<double>(r.cxy) * r.cxy;
  const double q = r.cyy * ux * ux - 2 * r.cxy * ux * uy + r.cxx * uy * uy;  // u' adj(C) u = det u' C^-1 u
  // The ellipse x' C^-1 x = 1 (radius one standard deviation): its diameter along u.
  if (det > 1e-9 && q > 1e-12) return 2 * std::sqrt(det / q);
  return 2 * std::sqrt(std::max(0.0, r.cxx * ux * ux + 2 * r.cxy * ux * uy + r.cyy * uy * uy));  // degenerate: a line
}

std::array<float, 4> pair_feature(const ModelRegion& a, const ModelRegion& b) {
  const auto& ca = a.colour;
  const auto& cb = b.colour;  // BGR
  const double rg_a = (ca[2] + 1.0) / (ca[1] + 1.0), bg_a = (ca[0] + 1.0) / (ca[1] + 1.0);
  const double rg_b = (cb[2] + 1.0) / (cb[1] + 1.0), bg_b = (cb[0] + 1.0) / (cb[1] + 1.0);
  const cv::Point2f d = b.centroid - a.centroid;
  const double dist = cv::norm(d);
  const cv::Point2f u = dist > 1e-9 ? cv::Point2f(static_cast<float>(d.x / dist), static_cast<float>(d.y / dist)) : cv::Point2f(1, 0);
  const double diameters = diameter_along(a, u) + diameter_along(b, u);
  return {compare_value(rg_a, rg_b), compare_value(bg_a, bg_b),
          compare_value(std::sqrt(std::max(0.0f, a.area)), std::sqrt(std::max(0.0f, b.area))),
          compare_value(dist, diameters)};
}

std::array<float, 3> individual_feature(const ModelRegion& r) {
  const auto& c = r.colour;
  const float s = std::clamp(r.straightness, 0.0f, 1.0f);
  return {compare_value(c[2] + 1.0, c[1] + 1.0), compare_value(c[0] + 1.0, c[1] + 1.0), 2 * s - 1};
}

bool describe_object(const std::vector<ModelRegion>& regions, const ObjectModelParams& p, ObjectDescription* out,
                     std::string* error) {
  auto fail = [&](const std::string& why) {
    if (error) *error = why;
    return false;
  };
  if (!out) return fail("describe_object: no output");
  *out = ObjectDescription{};
  if (regions.empty()) return fail("describe_object: an object needs at least one region");
  for (size_t i = 0; i < regions.size(); ++i) {
    if (!finite(regions[i])) return fail("describe_object: region " + std::to_string(i) + " has a non-finite value");
    if (!(regions[i].area > 0)) return fail("describe_object: region " + std::to_string(i) + " has no area");
  }
  if (p.max_regions < 1 || !(p.bin > 0) || !(p.tolerance >= 0) || !(p.scale_agree >= 1))
    return fail("describe_object: bad parameters (max_regions >= 1, bin > 0, tolerance >= 0, scale_agree >= 1)");
  // The largest regions, largest first (ties in the given order).
  std::vector<int> order(regions.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int x, int y) { return regions[x].area > regions[y].area; });
  if (order.size() > static_cast<size_t>(p.max_regions)) order.resize(p.max_regions);
  double area = 0, cx = 0, cy = 0;
  for (int i : order) {
    const ModelRegion& r = regions[i];
    out->regions.push_back(r);
    area += r.area;
    cx += static_cast<double>(r.area) * r.centroid.x;
    cy += static_cast<double>(r.area) * r.centroid.y;
  }
  out->scale = static_cast<float>(std::sqrt(area));
  out->centre = cv::Point2f(static_cast<float>(cx / area), static_cast<float>(cy / area));
  const size_t n = out->regions.size();
  for (const ModelRegion& r : out->regions) {
    out->size.push_back(std::sqrt(r.area) / out->scale);
    out->offset.push_back((r.centroid - out->centre) / out->scale);
    out->individual_features.push_back(individual_feature(r));
  }
  for (size_t i = 0; i < n; ++i)
    for (size_t j = 0; j < n; ++j) {
      if (i == j) continue;
      out->pairs.push_back({static_cast<int>(i), static_cast<int>(j)});
      out->pair_features.push_back(pair_feature(out->regions[i], out->regions[j]));
    }
  return true;
}

template <size_t N>
uint64_t ObjectModels::key_of(int type, const std::array<float, N>& v) const {
  const int bins = static_cast<int>(std::ceil(2.0 / p_.bin));
  uint64_t key = static_cast<uint64_t>(type);
  for (size_t d = 0; d < N; ++d) {
    const int b = std::clamp(static_cast<int>(std::floor((v[d] + 1.0) / p_.bin)), 0, bins - 1);
    key = (key << 8) | static_cast<uint64_t>(b & 0xff);
  }
  return key;
}

template <size_t N>
void ObjectModels::probe_keys(int type, const std::array<float, N>& v, std::vector<uint64_t>* keys) const {
  // Per dimension, the value's bin and, near an edge, the neighbour's; every combination.
  const int bins = static_cast<int>(std::ceil(2.0 / p_.bin));
  std::array<std::array<int, 2>, N> choice;
  std::array<int, N> count;
  for (size_t d = 0; d < N; ++d) {
    const double x = (v[d] + 1.0) / p_.bin;
    const int b = std::clamp(static_cast<int>(std::floor(x)), 0, bins - 1);
    choice[d][0] = b;
    count[d] = 1;
    const double frac = x - b;
    if (frac < p_.probe / p_.bin && b > 0) choice[d][count[d]++] = b - 1;
    else if (frac > 1 - p_.probe / p_.bin && b + 1 < bins) choice[d][count[d]++] = b + 1;
  }
  keys->clear();
  std::array<int, N> at{};
  while (true) {
    uint64_t key = static_cast<uint64_t>(type);
    for (size_t d = 0; d < N; ++d) key = (key << 8) | static_cast<uint64_t>(choice[d][at[d]] & 0xff);
    keys->push_back(key);
    size_t d = 0;
    while (d < N && ++at[d] == count[d]) at[d++] = 0;
    if (d == N) break;
  }
}

bool ObjectModels::add(int64_t id, const std::vector<ModelRegion>& regions, std::string* error) {
  ObjectDescription desc;
  if (!describe_object(regions, p_, &desc, error)) return false;
  remove(id);
  for (size_t k = 0; k < desc.pairs.size(); ++k) {
    table_[key_of(kPairType, desc.pair_features[k])].push_back({id, desc.pairs[k][0], desc.pairs[k][1]});
    ++entries_;
  }
  for (size_t i = 0; i < desc.individual_features.size(); ++i) {
    table_[key_of(kIndividualType, desc.individual_features[i])].push_back({id, static_cast<int>(i), -1});
    ++entries_;
  }
  models_.emplace(id, std::move(desc));
  return true;
}

bool ObjectModels::remove(int64_t id) {
  auto it = models_.find(id);
  if (it == models_.end()) return false;
  auto drop = [&](uint64_t key) {
    auto t = table_.find(key);
    if (t == table_.end()) return;
    auto& v = t->second;
    const size_t before = v.size();
    v.erase(std::remove_if(v.begin(), v.end(), [&](const Entry& e) { return e.model == id; }), v.end());
    entries_ -= before - v.size();
    if (v.empty()) table_.erase(t);
  };
  for (const auto& f : it->second.pair_features) drop(key_of(kPairType, f));
  for (const auto& f : it->second.individual_features) drop(key_of(kIndividualType, f));
  models_.erase(it);
  return true;
}

void ObjectModels::clear() {
  models_.clear();
  table_.clear();
  entries_ = 0;
}

Recognition ObjectModels::recognise(const std::vector<ModelRegion>& regions, std::string* error) const {
  Recognition out;
  if (regions.empty()) return out;
  ObjectDescription q;
  if (!describe_object(regions, p_, &q, error)) return out;
  if (models_.empty()) return out;
  std::map<int64_t, std::vector<Vote>> votes;  // by model
  std::vector<uint64_t> keys;
  const size_t n = q.regions.size();
  int feature = 0;
  auto within = [&](const auto& x, const auto& y) {
    for (size_t d = 0; d < x.size(); ++d)
      if (std::abs(x[d] - y[d]) > p_.tolerance) return false;
    return true;
  };
  // Pair features: each unordered pair once, as (i, j), i < j.
  for (size_t i = 0; i < n; ++i)
    for (size_t j = i + 1; j < n; ++j, ++feature) {
      const std::array<float, 4> f = pair_feature(q.regions[i], q.regions[j]);
      probe_keys(kPairType, f, &keys);
      for (uint64_t key : keys) {
        auto t = table_.find(key);
        if (t == table_.end()) continue;
        for (const Entry& e : t->second) {
          const ObjectDescription& m = models_.at(e.model);
          const size_t k = static_cast<size_t>(e.a) * (m.regions.size() - 1) + (e.b < e.a ? e.b : e.b - 1);
          if (!within(f, m.pair_features[k])) continue;
          const float s_model = m.size[e.a] + m.size[e.b];
          const float scale = (std::sqrt(q.regions[i].area) + std::sqrt(q.regions[j].area)) / s_model;
          const cv::Point2f mid = 0.5f * (q.regions[i].centroid + q.regions[j].centroid);
          const cv::Point2f off = 0.5f * (m.offset[e.a] + m.offset[e.b]);
          votes[e.model].push_back({feature, e.a, e.b, scale, mid - scale * off});
        }
      }
    }
  for (size_t i = 0; i < n; ++i, ++feature) {
    const std::array<float, 3> f = q.individual_features[i];
    probe_keys(kIndividualType, f, &keys);
    for (uint64_t key : keys) {
      auto t = table_.find(key);
      if (t == table_.end()) continue;
      for (const Entry& e : t->second) {
        const ObjectDescription& m = models_.at(e.model);
        if (!within(f, m.individual_features[e.a])) continue;
        const float scale = std::sqrt(q.regions[i].area) / m.size[e.a];
        votes[e.model].push_back({feature, e.a, -1, scale, q.regions[i].centroid - scale * m.offset[e.a]});
      }
    }
  }
  out.candidates = static_cast<int>(votes.size());
  const int query_features = feature;
  const double log_agree = std::log(p_.scale_agree);
  std::vector<char> counted(static_cast<size_t>(query_features), 0);
  for (auto& [id, vs] : votes) {
    // The order of the hash table's entries must not matter.
    std::sort(vs.begin(), vs.end(), [](const Vote& x, const Vote& y) {
      return std::tie(x.feature, x.a, x.b) < std::tie(y.feature, y.a, y.b);
    });
    int best = 0;
    float best_scale = 0;
    cv::Point2f best_centre;
    for (const Vote& v : vs) {
      std::fill(counted.begin(), counted.end(), 0);
      int agree = 0;
      double sum_s = 0;
      cv::Point2d sum_c(0, 0);
      for (const Vote& w : vs) {
        if (std::abs(std::log(w.scale / v.scale)) > log_agree) continue;
        if (cv::norm(w.centre - v.centre) > p_.centre_agree * v.scale) continue;
        if (counted[w.feature]) continue;
        counted[w.feature] = 1;
        ++agree;
        sum_s += w.scale;
        sum_c += cv::Point2d(w.centre.x, w.centre.y);
      }
      if (agree > best) {
        best = agree;
        best_scale = static_cast<float>(sum_s / agree);
        best_centre = cv::Point2f(static_cast<float>(sum_c.x / agree), static_cast<float>(sum_c.y / agree));
      }
    }
    const int smaller = std::min(models_.at(id).feature_count(), query_features);
    if (best < p_.min_votes || best < p_.min_fraction * smaller) {
      if (!out.recognised) out.votes = std::max(out.votes, best);  // the best losing tally
      continue;
    }
    if (!out.recognised || best > out.votes) {  // ties: the lower id (the map's order) stays
      out.recognised = true;
      out.id = id;
      out.votes = best;
      out.scale = best_scale;
      out.centre = best_centre;
    }
  }
  return out;
}

}  // namespace vigil::vision::mser
