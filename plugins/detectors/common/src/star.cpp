// CenSurE/STAR detector — see star.hpp for the contract and the filter definition.
#include "visnav/detectors/star.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <cstring>
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
// off: 4 offsets into S, 2 into A, 2 into B relative to the table index of pixel (0, y), and 2
// into the row C = A − B of that same row (the diamond's two corner reads on row y of A and B
// are merged into one read of C each). All arithmetic modulo 2^32.
VISNAV_STAR_CLONES
void star_row_kernel(const std::uint32_t* __restrict S, const std::uint32_t* __restrict A,
                     const std::uint32_t* __restrict B, const std::uint32_t* __restrict C, const std::ptrdiff_t* off,
                     int x0, int x1, std::uint32_t* __restrict out) {
  const std::uint32_t* __restrict s1 = S + off[0];
  const std::uint32_t* __restrict s2 = S + off[1];
  const std::uint32_t* __restrict s3 = S + off[2];
  const std::uint32_t* __restrict s4 = S + off[3];
  const std::uint32_t* __restrict a1 = A + off[4];
  const std::uint32_t* __restrict a4 = A + off[5];
  const std::uint32_t* __restrict b1 = B + off[6];
  const std::uint32_t* __restrict b4 = B + off[7];
  const std::uint32_t* __restrict c_right = C + off[8];
  const std::uint32_t* __restrict c_left = C + off[9];
#pragma GCC ivdep
  for (int x = x0; x < x1; ++x) {
    const std::uint32_t box = s1[x] - s2[x] - s3[x] + s4[x];
    const std::uint32_t diamond = (a1[x] + a4[x]) - (b1[x] + b4[x]) - (c_right[x] + c_left[x]);
    out[x] = box + diamond;
  }
}

// Up to kMaxScales scales (the ladder has 10 inner radii).
constexpr int kMaxScales = 10;

// Per-row scale ladder handed to the response kernel: the first `count` scales are evaluated.
struct RowScales {
  const std::int32_t* inner[kMaxScales];
  const std::int32_t* outer[kMaxScales];
  float inner_weight[kMaxScales];
  float ring_weight[kMaxScales];
};

float scale_response(std::int32_t in, std::int32_t outer, float wi, float wr) {
  const float fin = static_cast<float>(in);
  return fin * wi - (static_cast<float>(outer) - fin) * wr;
}

// Responses of the first `count` scales for x in [x0, x1): the response with the largest
// |value| wins (the first on ties); writes the signed winner and its scale index. Blocks of 8
// pixels keep the running winner in registers (8-lane GCC vector types: one AVX2 register, or
// two SSE2 registers on the baseline clone); the float operations are the same as the scalar
// tail's, so every pixel gets the same value whichever path computes it.
typedef float VFloat __attribute__((vector_size(32)));
typedef std::int32_t VInt __attribute__((vector_size(32)));

VISNAV_STAR_CLONES
void response_kernel(const RowScales& rs, int count, int x0, int x1, float* __restrict resp,
                     std::uint8_t* __restrict sc) {
  int x = x0;
  const VInt sign_mask = VInt{} + 0x7fffffff;
  for (; x + 8 <= x1; x += 8) {
    VFloat best{};
    VFloat best_abs{};
    VInt best_scale{};
    for (int i = 0; i < count; ++i) {
      VInt in;
      VInt outer;
      std::memcpy(&in, rs.inner[i] + x, sizeof in);
      std::memcpy(&outer, rs.outer[i] + x, sizeof outer);
      const VFloat fin = __builtin_convertvector(in, VFloat);
      const VFloat fout = __builtin_convertvector(outer, VFloat);
      const VFloat v = fin * rs.inner_weight[i] - (fout - fin) * rs.ring_weight[i];
      VFloat v_abs;
      VInt bits;
      std::memcpy(&bits, &v, sizeof bits);
      bits &= sign_mask;
      std::memcpy(&v_abs, &bits, sizeof v_abs);
      const VInt better = v_abs > best_abs;
      best = better ? v : best;
      best_abs = better ? v_abs : best_abs;
      best_scale = better ? VInt{} + i : best_scale;
    }
    std::memcpy(resp + x, &best, sizeof best);
    for (int j = 0; j < 8; ++j) sc[x + j] = static_cast<std::uint8_t>(best_scale[j]);
  }
  for (; x < x1; ++x) {
    float best = 0.0F;
    int best_scale = 0;
    for (int i = 0; i < count; ++i) {
      const float v = scale_response(rs.inner[i][x], rs.outer[i][x], rs.inner_weight[i], rs.ring_weight[i]);
      if (std::fabs(v) > std::fabs(best)) {
        best = v;
        best_scale = i;
      }
    }
    resp[x] = best;
    sc[x] = static_cast<std::uint8_t>(best_scale);
  }
}

// NMS helpers: running maximum / minimum of `window` consecutive values, out[x] over
// in[x − k .. x + k] for x in [k, w − k).
VISNAV_STAR_CLONES
void running_max_min(const float* __restrict in, int w, int k, float* __restrict out_max, float* __restrict out_min) {
  for (int x = k; x < w - k; ++x) {
    out_max[x] = in[x - k];
    out_min[x] = in[x - k];
  }
  for (int d = 1; d <= 2 * k; ++d) {
    const float* __restrict src = in + d - k;
    for (int x = k; x < w - k; ++x) {
      const float v = src[x];
      out_max[x] = out_max[x] < v ? v : out_max[x];
      out_min[x] = out_min[x] > v ? v : out_min[x];
    }
  }
}

// Flags pixels x in [x0, x1) of `row` whose value is beyond ±thr and equals the maximum (bright)
// or minimum (dark) of its window: the only possible keypoints (ties are settled afterwards).
// hmax/hmin: the `rows` horizontal running extrema rows of the window; wmax/wmin: scratch.
VISNAV_STAR_CLONES
void mark_candidates(const float* __restrict row, const float* const* hmax, const float* const* hmin, int rows,
                     float thr, int x0, int x1, std::uint8_t* __restrict flag) {
  int x = x0;
  for (; x + 8 <= x1; x += 8) {
    VFloat mx;
    VFloat mn;
    std::memcpy(&mx, hmax[0] + x, sizeof mx);
    std::memcpy(&mn, hmin[0] + x, sizeof mn);
    for (int r = 1; r < rows; ++r) {
      VFloat m;
      VFloat n;
      std::memcpy(&m, hmax[r] + x, sizeof m);
      std::memcpy(&n, hmin[r] + x, sizeof n);
      mx = mx < m ? m : mx;
      mn = mn > n ? n : mn;
    }
    VFloat v;
    std::memcpy(&v, row + x, sizeof v);
    const VInt is = ((v > thr) & (v >= mx)) | ((v < -thr) & (v <= mn));
    for (int j = 0; j < 8; ++j) flag[x + j] = static_cast<std::uint8_t>(is[j] & 1);
  }
  for (; x < x1; ++x) {
    float mx = hmax[0][x];
    float mn = hmin[0][x];
    for (int r = 1; r < rows; ++r) {
      mx = std::max(mx, hmax[r][x]);
      mn = std::min(mn, hmin[r][x]);
    }
    const float v = row[x];
    flag[x] = static_cast<std::uint8_t>(((v > thr) && v >= mx) || ((v < -thr) && v <= mn));
  }
}

// The three integral tables' rows for one image row (see StarDetector::build_tables).
VISNAV_STAR_CLONES
void table_rows(const std::uint32_t* __restrict rp, const std::uint32_t* __restrict sp, const std::uint32_t* __restrict ap,
                const std::uint32_t* __restrict bp, int w, std::uint32_t* __restrict s, std::uint32_t* __restrict a,
                std::uint32_t* __restrict b) {
  for (int c = 0; c <= w; ++c) s[c] = sp[c] + rp[c];
  for (int c = 0; c < w; ++c) a[c] = rp[c] + ap[c + 1];
  a[w] = rp[w];
  b[0] = 0;
  for (int c = 1; c <= w; ++c) b[c] = rp[c] + bp[c - 1];
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
    assert(scales_.empty() || s.margin_px >= scales_.back().margin_px);  // compute_responses relies on it
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
    const auto* sp = reinterpret_cast<const std::uint32_t*>(integral_.ptr<std::int32_t>(y));
    auto* s = reinterpret_cast<std::uint32_t*>(integral_.ptr<std::int32_t>(y + 1));
    const auto* ap = reinterpret_cast<const std::uint32_t*>(diag_a_.data()) + static_cast<std::size_t>(y) * stride;
    auto* a = reinterpret_cast<std::uint32_t*>(diag_a_.data()) + static_cast<std::size_t>(y + 1) * stride;
    const auto* bp = reinterpret_cast<const std::uint32_t*>(diag_b_.data()) + static_cast<std::size_t>(y) * stride;
    auto* b = reinterpret_cast<std::uint32_t*>(diag_b_.data()) + static_cast<std::size_t>(y + 1) * stride;
    table_rows(rp, sp, ap, bp, w, s, a, b);
  }
}

void StarDetector::compute_responses(int w, int h) {
  const int stride = w + 1;
  const std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  response_.resize(pixels);
  scale_.resize(pixels);
  for (auto& row : star_rows_) row.resize(static_cast<std::size_t>(w));
  diag_diff_.resize(static_cast<std::size_t>(stride));

  const auto* S = reinterpret_cast<const std::uint32_t*>(integral_.ptr<std::int32_t>(0));
  const auto* A = reinterpret_cast<const std::uint32_t*>(diag_a_.data());
  const auto* B = reinterpret_cast<const std::uint32_t*>(diag_b_.data());
  auto* C = reinterpret_cast<std::uint32_t*>(diag_diff_.data());
  std::vector<char>& needed = needed_;
  needed.resize(radii_.size());
  assert(scales_.size() <= static_cast<std::size_t>(kMaxScales));

  // Scales are ordered by size, so their margins ascend: at row y the first `count` scales fit,
  // and along the row scale i fits for x in [margin_i, w − margin_i).
  RowScales rs{};
  for (std::size_t i = 0; i < scales_.size(); ++i) {
    rs.inner[i] = star_rows_[static_cast<std::size_t>(scales_[i].inner)].data();
    rs.outer[i] = star_rows_[static_cast<std::size_t>(scales_[i].outer)].data();
    rs.inner_weight[i] = scales_[i].inner_weight;
    rs.ring_weight[i] = scales_[i].ring_weight;
  }

  for (int y = 0; y < h; ++y) {
    float* __restrict resp = response_.data() + static_cast<std::size_t>(y) * w;
    std::uint8_t* sc = scale_.data() + static_cast<std::size_t>(y) * w;

    std::fill(needed.begin(), needed.end(), 0);
    int count = 0;
    for (const Scale& s : scales_) {
      if (y < s.margin_px || y > h - 1 - s.margin_px || w <= 2 * s.margin_px) break;
      needed[static_cast<std::size_t>(s.inner)] = 1;
      needed[static_cast<std::size_t>(s.outer)] = 1;
      ++count;
    }
    if (count == 0) {
      std::fill(resp, resp + w, 0.0F);
      std::fill(sc, sc + w, std::uint8_t{0});
      continue;
    }

    const std::size_t row_base = static_cast<std::size_t>(y + 1) * stride + 1;  // index of pixel (0, y)
    {
      const std::uint32_t* a = A + row_base - 1;
      const std::uint32_t* b = B + row_base - 1;
      for (int c = 0; c <= w; ++c) C[c] = a[c] - b[c];
    }
    for (std::size_t k = 0; k < radii_.size(); ++k) {
      if (!needed[k]) continue;
      const Radius& rad = radii_[k];
      const int n = rad.box_half_px;
      const int r = rad.diamond_radius_px;
      const int m = rad.margin_px;
      const std::ptrdiff_t st = stride;
      const std::ptrdiff_t base = static_cast<std::ptrdiff_t>(row_base);
      // Box: S at rows y+n / y−n−1, columns x+n / x−n−1. Diamond: A and B at rows y+r and
      // y−r−1, plus C(x+r) and C(x−r−1) on row y (C[0] is column −1).
      const std::ptrdiff_t offsets[10] = {n * st + n, -(n + 1) * st + n, n * st - n - 1, -(n + 1) * st - n - 1,
                                          r * st,     -(r + 1) * st,     r * st - 1,     -(r + 1) * st - 1,
                                          r + 1,      -r};
      star_row_kernel(S + base, A + base, B + base, C, offsets, m, w - m,
                      reinterpret_cast<std::uint32_t*>(star_rows_[k].data()));
    }

    // Segments of the row by the number of scales that fit: [lo_i, lo_{i+1}) and
    // [hi_{i+1}, hi_i) have i + 1 scales, [lo_{count−1}, hi_{count−1}) all of them.
    const int lo0 = scales_.front().margin_px;
    std::fill(resp, resp + lo0, 0.0F);
    std::fill(sc, sc + lo0, std::uint8_t{0});
    std::fill(resp + (w - lo0), resp + w, 0.0F);
    std::fill(sc + (w - lo0), sc + w, std::uint8_t{0});
    for (int i = 0; i < count; ++i) {
      const int lo = scales_[static_cast<std::size_t>(i)].margin_px;
      const int hi = w - lo;
      if (i + 1 == count) {
        response_kernel(rs, count, lo, hi, resp, sc);
      } else {
        const int lo_next = scales_[static_cast<std::size_t>(i + 1)].margin_px;
        response_kernel(rs, i + 1, lo, lo_next, resp, sc);
        response_kernel(rs, i + 1, w - lo_next, hi, resp, sc);
      }
    }
  }
}

bool StarDetector::is_line(int x, int y, int scale, int w, int h) const {
  const int n_out = scales_[static_cast<std::size_t>(scale)].outer_half_px;
  const int delta = std::max(1, n_out / 4);
  const int radius = 4 * delta;
  // The 9×9 sample grid, clipped to keep one pixel for the central differences.
  auto first = [&](int c) { return c - radius >= 1 ? 0 : (1 - (c - radius) + delta - 1) / delta; };
  auto last = [&](int c, int size) { return c + radius <= size - 2 ? 8 : 8 - (c + radius - (size - 2) + delta - 1) / delta; };
  const int jy0 = first(y), jy1 = last(y, h), jx0 = first(x), jx1 = last(x, w);
  const std::ptrdiff_t row = w;
  // Index of sample (jx, jy) = origin + jy·step_y + jx·delta (only valid samples are formed).
  const std::ptrdiff_t origin = static_cast<std::ptrdiff_t>(y - radius) * row + (x - radius);
  const std::ptrdiff_t step_y = static_cast<std::ptrdiff_t>(delta) * row;
  const float* resp = response_.data();
  // (a) projected: second-moment matrix of the response gradients.
  double lxx = 0, lyy = 0, lxy = 0;
  for (int jy = jy0; jy <= jy1; ++jy) {
    for (int jx = jx0; jx <= jx1; ++jx) {
      const float* q = resp + (origin + jy * step_y + jx * delta);
      const double lx = q[1] - q[-1];
      const double ly = q[row] - q[-row];
      lxx += lx * lx;
      lyy += ly * ly;
      lxy += lx * ly;
    }
  }
  const double tr = lxx + lyy;
  if (tr > 0.0 && tr * tr >= params_.line_threshold_projected * (lxx * lyy - lxy * lxy)) return true;
  // (b) binarised: the same on "this pixel chose the same scale".
  const std::uint8_t* sc = scale_.data();
  const auto target = static_cast<std::uint8_t>(scale);
  int bxx = 0, byy = 0, bxy = 0;
  for (int jy = jy0; jy <= jy1; ++jy) {
    for (int jx = jx0; jx <= jx1; ++jx) {
      const std::uint8_t* q = sc + (origin + jy * step_y + jx * delta);
      const int bx = int(q[1] == target) - int(q[-1] == target);
      const int by = int(q[row] == target) - int(q[-row] == target);
      bxx += bx * bx;
      byy += by * by;
      bxy += bx * by;
    }
  }
  const double trb = bxx + byy;
  const double detb = static_cast<double>(bxx) * byy - static_cast<double>(bxy) * bxy;
  return trb > 0.0 && trb * trb >= params_.line_threshold_binarized * detb;
}

void StarDetector::find_extrema(int w, int h, std::vector<cv::KeyPoint>& keypoints) {
  const int k = params_.suppress_nonmax_size_px / 2;
  const int window = 2 * k + 1;
  const int edge = std::max(params_.border_px, k);
  if (h - 2 * edge <= 0 || w - 2 * edge <= 0) return;
  const auto thr = static_cast<float>(params_.response_threshold);
  const float* resp = response_.data();
  const auto row_len = static_cast<std::size_t>(w);
  row_max_.resize(static_cast<std::size_t>(window) * row_len);
  row_min_.resize(static_cast<std::size_t>(window) * row_len);
  candidate_.assign(row_len + 8, 0);
  auto ring = [&](std::vector<float>& buf, int row) {
    return buf.data() + static_cast<std::size_t>(row % window) * row_len;
  };
  // Horizontal running extrema of rows edge−k .. edge+k−1 first; one more row per output row.
  for (int r = edge - k; r < edge + k; ++r)
    running_max_min(resp + static_cast<std::size_t>(r) * row_len, w, k, ring(row_max_, r), ring(row_min_, r));

  for (int y = edge; y < h - edge; ++y) {
    running_max_min(resp + static_cast<std::size_t>(y + k) * row_len, w, k, ring(row_max_, y + k), ring(row_min_, y + k));
    const float* hmax[32];
    const float* hmin[32];
    for (int r = 0; r < window; ++r) {
      hmax[r] = ring(row_max_, y - k + r);
      hmin[r] = ring(row_min_, y - k + r);
    }
    const float* row = resp + static_cast<std::size_t>(y) * row_len;
    std::uint8_t* flag = candidate_.data();
    mark_candidates(row, hmax, hmin, window, thr, edge, w - edge, flag);

    for (int x0 = edge; x0 < w - edge; x0 += 8) {
      std::uint64_t word = 0;
      std::memcpy(&word, flag + x0, sizeof word);  // flags beyond w − edge are 0
      if (word == 0) continue;
      for (int x = x0; x < std::min(x0 + 8, w - edge); ++x) {
        if (!flag[x]) continue;
        // No neighbour is stronger; a neighbour equal to v wins when it comes earlier in
        // raster order (ties settle on the first pixel).
        const float v = row[x];
        bool extremum = true;
        for (int dy = -k; dy <= 0 && extremum; ++dy) {
          const float* nrow = row + static_cast<std::ptrdiff_t>(dy) * w;
          const int dx_end = dy < 0 ? k : -1;
          for (int dx = -k; dx <= dx_end; ++dx) {
            if (nrow[x + dx] == v) {
              extremum = false;
              break;
            }
          }
        }
        if (!extremum) continue;
        const int scale = scale_[static_cast<std::size_t>(y) * row_len + static_cast<std::size_t>(x)];
        if (is_line(x, y, scale, w, h)) continue;
        keypoints.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(scale_size_px(scale)),
                               -1.0F, std::fabs(v), scale, v > 0 ? 1 : -1);
      }
    }
  }
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
  find_extrema(w, h, keypoints);
}

}  // namespace visnav::detectors
