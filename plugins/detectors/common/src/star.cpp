// CenSurE/STAR detector — see star.hpp for the contract and the filter definition.
#include "visnav/detectors/star.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

namespace visnav::detectors {

namespace {

// Inner radii of the scale ladder (outer radius = 2 × inner), roughly √2 apart like the
// historic STAR implementation's filter sizes.
constexpr int kInnerRadii[] = {1, 2, 3, 4, 6, 8, 11, 16, 23, 32};

int diamond_radius(int box_half) { return static_cast<int>(std::lround(box_half * std::sqrt(2.0))); }

// Hot loops, compiled for AVX2 and a baseline fallback (picked at load time).
#if defined(__x86_64__) && defined(__GNUC__)
#define VISNAV_STAR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define VISNAV_STAR_CLONES
#endif

// Star sums of one row: upright box (integral S) + diamond (slanted tables A, B), x in [x0, x1).
// off: 4 offsets into S, 4 into A, 4 into B, relative to the table index of pixel (0, y).
VISNAV_STAR_CLONES
void star_row_kernel(const std::uint32_t* __restrict S, const std::uint32_t* __restrict A,
                     const std::uint32_t* __restrict B, const std::ptrdiff_t* off, int x0, int x1,
                     std::uint32_t* __restrict out) {
  const std::uint32_t* __restrict s1 = S + off[0];
  const std::uint32_t* __restrict s2 = S + off[1];
  const std::uint32_t* __restrict s3 = S + off[2];
  const std::uint32_t* __restrict s4 = S + off[3];
  const std::uint32_t* __restrict a1 = A + off[4];
  const std::uint32_t* __restrict a2 = A + off[5];
  const std::uint32_t* __restrict a3 = A + off[6];
  const std::uint32_t* __restrict a4 = A + off[7];
  const std::uint32_t* __restrict b1 = B + off[8];
  const std::uint32_t* __restrict b2 = B + off[9];
  const std::uint32_t* __restrict b3 = B + off[10];
  const std::uint32_t* __restrict b4 = B + off[11];
#pragma GCC ivdep
  for (int x = x0; x < x1; ++x) {
    const std::uint32_t box = s1[x] - s2[x] - s3[x] + s4[x];
    const std::uint32_t da = a1[x] - a2[x] - a3[x] + a4[x];
    const std::uint32_t db = b2[x] + b3[x] - b1[x] - b4[x];
    out[x] = box + da + db;
  }
}

// Response of one scale for one row; keeps the larger |response| and its scale index.
VISNAV_STAR_CLONES
void response_row_kernel(const std::int32_t* __restrict in, const std::int32_t* __restrict outer, float wi, float wr,
                         std::int32_t idx, int x0, int x1, float* __restrict resp, std::int32_t* __restrict bs) {
#pragma GCC ivdep
  for (int x = x0; x < x1; ++x) {
    const float fin = static_cast<float>(in[x]);
    const float v = fin * wi - (static_cast<float>(outer[x]) - fin) * wr;
    const float cur = resp[x];
    const bool better = std::fabs(v) > std::fabs(cur);
    resp[x] = better ? v : cur;
    bs[x] = better ? idx : bs[x];
  }
}

}  // namespace

Status StarParams::validate() const {
  if (max_size_px < 5 || max_size_px > 129)
    return fail("max_size_px " + std::to_string(max_size_px) + " is out of range [5, 129]");
  if (!(response_threshold > 0.0)) return fail("response_threshold must be > 0");
  if (!(line_threshold_projected > 0.0)) return fail("line_threshold_projected must be > 0");
  if (!(line_threshold_binarized > 0.0)) return fail("line_threshold_binarized must be > 0");
  if (suppress_nonmax_size_px < 3 || suppress_nonmax_size_px > 31 || suppress_nonmax_size_px % 2 == 0)
    return fail("suppress_nonmax_size_px " + std::to_string(suppress_nonmax_size_px) + " must be odd in [3, 31]");
  if (border_px < 0) return fail("border_px must be >= 0");
  return ok();
}

StarDetector::StarDetector(const StarParams& params) : params_(params) {
  assert(params.validate().ok());
  build_scales();
}

Status StarDetector::set_params(const StarParams& params) {
  VISNAV_TRY(params.validate());
  const bool rebuild = params.max_size_px != params_.max_size_px;
  params_ = params;
  if (rebuild) build_scales();
  return ok();
}

int StarDetector::scale_size_px(int index) const {
  return 2 * scales_.at(static_cast<std::size_t>(index)).outer_half_px + 1;
}

void StarDetector::build_scales() {
  radii_.clear();
  scales_.clear();
  auto radius_index = [this](int n) {
    for (std::size_t i = 0; i < radii_.size(); ++i)
      if (radii_[i].box_half_px == n) return static_cast<int>(i);
    const int r = diamond_radius(n);
    const double box = (2.0 * n + 1) * (2.0 * n + 1);
    const double diamond = 2.0 * r * r + 2.0 * r + 1.0;
    radii_.push_back(Radius{n, r, std::max(n, r), box + diamond});
    return static_cast<int>(radii_.size() - 1);
  };
  for (int inner : kInnerRadii) {
    const int outer = 2 * inner;
    if (2 * outer + 1 > params_.max_size_px) break;
    Scale s{};
    s.inner = radius_index(inner);
    s.outer = radius_index(outer);
    const double a_in = radii_[static_cast<std::size_t>(s.inner)].area;
    const double a_out = radii_[static_cast<std::size_t>(s.outer)].area;
    s.inner_weight = static_cast<float>(1.0 / a_in);
    s.ring_weight = static_cast<float>(1.0 / (a_out - a_in));
    s.outer_half_px = outer;
    s.margin_px = radii_[static_cast<std::size_t>(s.outer)].margin_px;
    scales_.push_back(s);
  }
  star_rows_.resize(radii_.size());
}

// Tables share one layout: (h+1) rows × (w+1) columns, entry (y+1, x+1) for pixel (x, y), x and
// y from -1. R(x, y) is the row prefix sum of row y up to and including column x (R(-1, y) = 0).
//   integral: S(x, y) = Σ_{y' ≤ y} R(x, y')
//   diag_a:   A(x, y) = R(x, y) + A(x+1, y−1)   (chain towards the upper right, cut at the right edge)
//   diag_b:   B(x, y) = R(x, y) + B(x−1, y−1)   (chain towards the upper left, cut at x = −1)
// Differences along one chain give sums of row prefixes along a 45° line, i.e. the left or right
// boundary of a diamond. Arithmetic is modulo 2^32 (unsigned), exact for every window sum.
void StarDetector::build_tables(const cv::Mat& grey) {
  const int w = grey.cols;
  const int h = grey.rows;
  const int stride = w + 1;
  integral_.create(h + 1, w + 1, CV_32S);
  const std::size_t cells = static_cast<std::size_t>(h + 1) * static_cast<std::size_t>(stride);
  if (diag_a_.size() != cells) {
    diag_a_.assign(cells, 0);
    diag_b_.assign(cells, 0);
  }
  row_prefix_.resize(static_cast<std::size_t>(stride));
  auto* s0 = reinterpret_cast<std::uint32_t*>(integral_.ptr<std::int32_t>(0));
  std::fill(s0, s0 + stride, 0U);
  std::fill(diag_a_.begin(), diag_a_.begin() + stride, 0);
  std::fill(diag_b_.begin(), diag_b_.begin() + stride, 0);
  auto* rp = reinterpret_cast<std::uint32_t*>(row_prefix_.data());
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* src = grey.ptr<std::uint8_t>(y);
    std::uint32_t acc = 0;
    rp[0] = 0;
    for (int x = 0; x < w; ++x) {
      acc += src[x];
      rp[x + 1] = acc;
    }
    const auto* __restrict sp = reinterpret_cast<const std::uint32_t*>(integral_.ptr<std::int32_t>(y));
    auto* __restrict s = reinterpret_cast<std::uint32_t*>(integral_.ptr<std::int32_t>(y + 1));
    const auto* __restrict ap = reinterpret_cast<const std::uint32_t*>(diag_a_.data()) + static_cast<std::size_t>(y) * stride;
    auto* __restrict a = reinterpret_cast<std::uint32_t*>(diag_a_.data()) + static_cast<std::size_t>(y + 1) * stride;
    const auto* __restrict bp = reinterpret_cast<const std::uint32_t*>(diag_b_.data()) + static_cast<std::size_t>(y) * stride;
    auto* __restrict b = reinterpret_cast<std::uint32_t*>(diag_b_.data()) + static_cast<std::size_t>(y + 1) * stride;
    for (int c = 0; c <= w; ++c) s[c] = sp[c] + rp[c];
    for (int c = 0; c < w; ++c) a[c] = rp[c] + ap[c + 1];
    a[w] = rp[w];
    b[0] = 0;
    for (int c = 1; c <= w; ++c) b[c] = rp[c] + bp[c - 1];
  }
}

void StarDetector::compute_responses(int w, int h) {
  const int stride = w + 1;
  const std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  response_.resize(pixels);
  scale_.resize(pixels);
  for (auto& row : star_rows_) row.resize(static_cast<std::size_t>(w));
  std::vector<std::int32_t>& best_scale = row_prefix_;  // reused as an int row buffer (size w+1)

  const auto* S = reinterpret_cast<const std::uint32_t*>(integral_.ptr<std::int32_t>(0));
  const auto* A = reinterpret_cast<const std::uint32_t*>(diag_a_.data());
  const auto* B = reinterpret_cast<const std::uint32_t*>(diag_b_.data());
  std::vector<char>& needed = needed_;
  needed.resize(radii_.size());

  for (int y = 0; y < h; ++y) {
    float* __restrict resp = response_.data() + static_cast<std::size_t>(y) * w;
    std::uint8_t* sc = scale_.data() + static_cast<std::size_t>(y) * w;
    std::fill(resp, resp + w, 0.0F);
    std::fill(sc, sc + w, std::uint8_t{0});

    std::fill(needed.begin(), needed.end(), 0);
    bool any = false;
    for (const Scale& s : scales_) {
      if (y < s.margin_px || y > h - 1 - s.margin_px || w <= 2 * s.margin_px) continue;
      needed[static_cast<std::size_t>(s.inner)] = 1;
      needed[static_cast<std::size_t>(s.outer)] = 1;
      any = true;
    }
    if (!any) continue;

    const std::size_t row_base = static_cast<std::size_t>(y + 1) * stride + 1;  // index of pixel (0, y)
    for (std::size_t k = 0; k < radii_.size(); ++k) {
      if (!needed[k]) continue;
      const Radius& rad = radii_[k];
      const int n = rad.box_half_px;
      const int r = rad.diamond_radius_px;
      const int m = rad.margin_px;
      const std::ptrdiff_t st = stride;
      const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(row_base);
      const std::ptrdiff_t offsets[12] = {n * st + n,       -(n + 1) * st + n, n * st - n - 1,  -(n + 1) * st - n - 1,
                                          r * st,           r,                 -r - 1,          -(r + 1) * st,
                                          r * st - 1,       -r - 1,            r,               -(r + 1) * st - 1};
      star_row_kernel(S + base, A + base, B + base, offsets, m, w - m, reinterpret_cast<std::uint32_t*>(star_rows_[k].data()));
    }

    std::fill(best_scale.begin(), best_scale.begin() + w, 0);
    std::int32_t* __restrict bs = best_scale.data();
    for (std::size_t i = 0; i < scales_.size(); ++i) {
      const Scale& s = scales_[i];
      if (y < s.margin_px || y > h - 1 - s.margin_px || w <= 2 * s.margin_px) continue;
      const std::int32_t* __restrict in = star_rows_[static_cast<std::size_t>(s.inner)].data();
      const std::int32_t* __restrict outer = star_rows_[static_cast<std::size_t>(s.outer)].data();
      response_row_kernel(in, outer, s.inner_weight, s.ring_weight, static_cast<std::int32_t>(i), s.margin_px,
                          w - s.margin_px, resp, bs);
    }
    for (int x = 0; x < w; ++x) sc[x] = static_cast<std::uint8_t>(bs[x]);
  }
}

bool StarDetector::is_line(int x, int y, int scale, int w, int h) const {
  const int n_out = scales_[static_cast<std::size_t>(scale)].outer_half_px;
  const int delta = std::max(1, n_out / 4);
  const int radius = 4 * delta;
  const float* resp = response_.data();
  const std::uint8_t* sc = scale_.data();
  const auto target = static_cast<std::uint8_t>(scale);
  double lxx = 0, lyy = 0, lxy = 0;
  int bxx = 0, byy = 0, bxy = 0;
  for (int sy = y - radius; sy <= y + radius; sy += delta) {
    if (sy < 1 || sy > h - 2) continue;
    for (int sx = x - radius; sx <= x + radius; sx += delta) {
      if (sx < 1 || sx > w - 2) continue;
      const std::size_t i = static_cast<std::size_t>(sy) * w + sx;
      const double lx = resp[i + 1] - resp[i - 1];
      const double ly = resp[i + w] - resp[i - w];
      lxx += lx * lx;
      lyy += ly * ly;
      lxy += lx * ly;
      const int bx = int(sc[i + 1] == target) - int(sc[i - 1] == target);
      const int by = int(sc[i + w] == target) - int(sc[i - w] == target);
      bxx += bx * bx;
      byy += by * by;
      bxy += bx * by;
    }
  }
  const double tr = lxx + lyy;
  if (tr > 0.0 && tr * tr >= params_.line_threshold_projected * (lxx * lyy - lxy * lxy)) return true;
  const double trb = bxx + byy;
  const double detb = static_cast<double>(bxx) * byy - static_cast<double>(bxy) * bxy;
  return trb > 0.0 && trb * trb >= params_.line_threshold_binarized * detb;
}

void StarDetector::detect(const cv::Mat& grey, std::vector<cv::KeyPoint>& keypoints) {
  keypoints.clear();
  assert(grey.empty() || grey.type() == CV_8UC1);
  if (grey.empty() || scales_.empty()) return;
  const int w = grey.cols;
  const int h = grey.rows;
  build_tables(grey);
  // Smallest filter margin: nothing can be found on images that do not fit it.
  if (w <= 2 * scales_.front().margin_px || h <= 2 * scales_.front().margin_px) return;
  compute_responses(w, h);

  const int k = params_.suppress_nonmax_size_px / 2;
  const int edge = std::max(params_.border_px, k);
  const auto thr = static_cast<float>(params_.response_threshold);
  const float* resp = response_.data();
  for (int y = edge; y < h - edge; ++y) {
    const float* row = resp + static_cast<std::size_t>(y) * w;
    for (int x = edge; x < w - edge; ++x) {
      const float v = row[x];
      if (!(v > thr || v < -thr)) continue;
      bool extremum = true;
      for (int dy = -k; dy <= k && extremum; ++dy) {
        const float* nrow = row + static_cast<std::ptrdiff_t>(dy) * w;
        for (int dx = -k; dx <= k; ++dx) {
          if (dx == 0 && dy == 0) continue;
          const float nv = nrow[x + dx];
          const bool earlier = dy < 0 || (dy == 0 && dx < 0);
          const bool beaten = v > 0 ? (nv > v || (earlier && nv == v)) : (nv < v || (earlier && nv == v));
          if (beaten) {
            extremum = false;
            break;
          }
        }
      }
      if (!extremum) continue;
      const int scale = scale_[static_cast<std::size_t>(y) * w + x];
      if (is_line(x, y, scale, w, h)) continue;
      cv::KeyPoint kp(static_cast<float>(x), static_cast<float>(y), static_cast<float>(scale_size_px(scale)), -1.0F,
                      std::fabs(v), scale, v > 0 ? 1 : -1);
      keypoints.push_back(kp);
    }
  }
}

}  // namespace visnav::detectors
