// Texture construction: photographs (tinted grey or colour images) and procedural patterns.
// All procedural textures tile seamlessly and carry fine high-frequency detail so that corner
// detectors find keypoints on them at 320x240.
#include "textures.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "yaml_util.hpp"
#include "visnav/file_io.hpp"

namespace visnav::sim::detail {
namespace {

namespace fs = std::filesystem;

/// Periodic value noise in [-1, 1]: `octaves` octaves starting at `cells` lattice cells per side.
cv::Mat1f periodic_noise(int side, int cells, int octaves, std::mt19937& rng) {
  cv::Mat1f out(side, side, 0.0f);
  std::uniform_real_distribution<float> uni(-1.0f, 1.0f);
  float amplitude = 1.0f;
  float total = 0.0f;
  for (int o = 0; o < octaves && cells <= side; ++o, cells *= 2, amplitude *= 0.5f) {
    std::vector<float> lattice(static_cast<size_t>(cells) * cells);
    for (auto& v : lattice) v = uni(rng);
    const float scale = static_cast<float>(cells) / static_cast<float>(side);
    for (int y = 0; y < side; ++y) {
      const float fy = (static_cast<float>(y) + 0.5f) * scale;
      const int y0 = static_cast<int>(std::floor(fy));
      float ty = fy - static_cast<float>(y0);
      ty = ty * ty * (3.0f - 2.0f * ty);
      const int ya = ((y0 % cells) + cells) % cells;
      const int yb = (ya + 1) % cells;
      float* row = out[y];
      for (int x = 0; x < side; ++x) {
        const float fx = (static_cast<float>(x) + 0.5f) * scale;
        const int x0 = static_cast<int>(std::floor(fx));
        float tx = fx - static_cast<float>(x0);
        tx = tx * tx * (3.0f - 2.0f * tx);
        const int xa = ((x0 % cells) + cells) % cells;
        const int xb = (xa + 1) % cells;
        const float a = lattice[static_cast<size_t>(ya) * cells + xa], b = lattice[static_cast<size_t>(ya) * cells + xb];
        const float c = lattice[static_cast<size_t>(yb) * cells + xa], d = lattice[static_cast<size_t>(yb) * cells + xb];
        row[x] += amplitude * ((a + (b - a) * tx) * (1.0f - ty) + (c + (d - c) * tx) * ty);
      }
    }
    total += amplitude;
  }
  if (total > 0.0f) out *= 1.0f / total;
  return out;
}

cv::Vec3f rgb_to_bgrf(const std::vector<double>& rgb) {
  return cv::Vec3f(static_cast<float>(rgb[2]), static_cast<float>(rgb[1]), static_cast<float>(rgb[0]));
}

/// Writes colour * (1 + shade) into BGRA (alpha 255).
void put(cv::Mat& bgra, int y, int x, const cv::Vec3f& color, float shade, unsigned char alpha = 255) {
  cv::Vec4b& p = bgra.at<cv::Vec4b>(y, x);
  for (int c = 0; c < 3; ++c) p[c] = cv::saturate_cast<unsigned char>(color[c] * (1.0f + shade));
  p[3] = alpha;
}

struct Proc {
  int side = 512;
  double size_m = 2.0;
  cv::Vec3f color{128, 128, 128};
  cv::Vec3f color2{90, 90, 90};
  double detail = 0.12;
  std::mt19937 rng;
};

cv::Mat make_noise(Proc& p, double feature_m) {
  const int cells = std::clamp(static_cast<int>(std::lround(p.size_m / std::max(feature_m, 1e-3))), 1, p.side / 2);
  cv::Mat1f coarse = periodic_noise(p.side, cells, 4, p.rng);
  cv::Mat1f fine = periodic_noise(p.side, std::min(p.side / 2, 128), 2, p.rng);
  cv::Mat out(p.side, p.side, CV_8UC4);
  for (int y = 0; y < p.side; ++y)
    for (int x = 0; x < p.side; ++x) {
      const float t = std::clamp(0.5f + 0.8f * coarse(y, x), 0.0f, 1.0f);
      const cv::Vec3f c = p.color * (1.0f - t) + p.color2 * t;
      put(out, y, x, c, static_cast<float>(p.detail) * 2.0f * fine(y, x));
    }
  return out;
}

/// Rectangular cells (tiles or bricks): cell size in texels, optional half offset on odd rows.
cv::Mat make_cells(Proc& p, double cell_w_m, double cell_h_m, double grout_m, bool offset_rows) {
  const int nx = std::max(1, static_cast<int>(std::lround(p.size_m / cell_w_m)));
  const int ny = std::max(1, static_cast<int>(std::lround(p.size_m / cell_h_m)));
  const double texel_m = p.size_m / p.side;
  const int grout_px = std::max(1, static_cast<int>(std::lround(grout_m / texel_m)));
  std::uniform_real_distribution<float> jitter(-0.12f, 0.12f);
  std::vector<float> cell_shade(static_cast<size_t>(nx) * ny * 2);
  for (auto& s : cell_shade) s = jitter(p.rng);
  cv::Mat1f fine = periodic_noise(p.side, std::min(p.side / 2, 128), 2, p.rng);
  cv::Mat1f mid = periodic_noise(p.side, std::max(4, nx * 2), 2, p.rng);
  cv::Mat out(p.side, p.side, CV_8UC4);
  for (int y = 0; y < p.side; ++y) {
    const double cy = static_cast<double>(y) * ny / p.side;
    const int row = static_cast<int>(cy);
    const int in_y = y - static_cast<int>(std::lround(static_cast<double>(row) * p.side / ny));
    for (int x = 0; x < p.side; ++x) {
      double cxd = static_cast<double>(x) * nx / p.side + ((offset_rows && (row % 2 == 1)) ? 0.5 : 0.0);
      if (cxd >= nx) cxd -= nx;
      const int col = static_cast<int>(cxd);
      const int in_x = static_cast<int>((cxd - col) * p.side / nx);
      const bool grout = in_y < grout_px || in_x < grout_px;
      const float noise = static_cast<float>(p.detail) * (2.0f * fine(y, x) + 0.8f * mid(y, x));
      if (grout) {
        put(out, y, x, p.color2, noise * 0.5f);
      } else {
        const float shade = cell_shade[static_cast<size_t>(row) * nx + col];
        put(out, y, x, p.color, shade + noise);
      }
    }
  }
  return out;
}

cv::Mat make_planks(Proc& p, double plank_m, double gap_m) {
  const int n = std::max(1, static_cast<int>(std::lround(p.size_m / plank_m)));
  const double texel_m = p.size_m / p.side;
  const int gap_px = std::max(1, static_cast<int>(std::lround(gap_m / texel_m)));
  std::uniform_real_distribution<float> jitter(-0.15f, 0.15f);
  std::vector<float> shade(static_cast<size_t>(n));
  for (auto& s : shade) s = jitter(p.rng);
  cv::Mat1f grain = periodic_noise(p.side, 8, 3, p.rng);
  cv::Mat1f fine = periodic_noise(p.side, std::min(p.side / 2, 128), 2, p.rng);
  cv::Mat out(p.side, p.side, CV_8UC4);
  for (int y = 0; y < p.side; ++y)
    for (int x = 0; x < p.side; ++x) {
      const int plank = x * n / p.side;
      const int in_x = x - plank * p.side / n;
      if (in_x < gap_px) {
        put(out, y, x, p.color2, 0.0f);
      } else {
        const float g = 0.25f * std::sin(static_cast<float>(x) * 0.9f + 6.0f * grain(y, x));
        put(out, y, x, p.color, shade[static_cast<size_t>(plank)] + g * 0.5f + static_cast<float>(p.detail) * 2.0f * fine(y, x));
      }
    }
  return out;
}

/// Building facade: plaster with a grid of framed windows (strong corners).
cv::Mat make_facade(Proc& p, double bay_m, double storey_m, double window_w_m, double window_h_m, double sill_m) {
  cv::Mat out = make_noise(p, 0.3);
  const int bays = std::max(1, static_cast<int>(std::lround(p.size_m / bay_m)));
  const int storeys = std::max(1, static_cast<int>(std::lround(p.size_m / storey_m)));
  const double px_per_m = p.side / p.size_m;
  const int ww = static_cast<int>(window_w_m * px_per_m), wh = static_cast<int>(window_h_m * px_per_m);
  const int frame = std::max(2, static_cast<int>(0.06 * px_per_m));
  std::uniform_real_distribution<float> glass(0.0f, 1.0f);
  cv::Mat1f fine = periodic_noise(p.side, std::min(p.side / 2, 128), 2, p.rng);
  for (int s = 0; s < storeys; ++s)
    for (int b = 0; b < bays; ++b) {
      const int x0 = static_cast<int>((b + 0.5) * p.side / bays) - ww / 2;
      // texture row 0 is the top; storey s counted from the bottom (z = 0 at the last row)
      const int bottom = p.side - static_cast<int>(s * p.side / storeys + sill_m * px_per_m);
      const int y0 = bottom - wh;
      const float reflect = glass(p.rng);
      for (int y = std::max(0, y0 - frame); y < std::min(p.side, bottom + frame); ++y)
        for (int x = std::max(0, x0 - frame); x < std::min(p.side, x0 + ww + frame); ++x) {
          const bool inside = y >= y0 && y < bottom && x >= x0 && x < x0 + ww;
          const bool bar = std::abs(x - (x0 + ww / 2)) < frame / 2 + 1 || std::abs(y - (y0 + wh / 3)) < frame / 2 + 1;
          if (!inside || bar) {
            put(out, y, x, cv::Vec3f(235, 235, 230), 0.05f * fine(y, x));
          } else {
            const float t = static_cast<float>(y - y0) / static_cast<float>(std::max(1, wh));
            const cv::Vec3f sky(150 + 60 * reflect, 120 + 40 * reflect, 90);
            put(out, y, x, sky * (1.0f - 0.5f * t), 0.25f * fine(y, x));
          }
        }
    }
  return out;
}

/// Tree billboard with alpha: trunk and a ragged, leafy crown.
cv::Mat make_tree(Proc& p) {
  const int side = p.side;
  cv::Mat1f blob = periodic_noise(side, 6, 3, p.rng);
  cv::Mat1f leaves = periodic_noise(side, std::min(side / 2, 96), 2, p.rng);
  cv::Mat out(side, side, CV_8UC4, cv::Scalar(0, 0, 0, 0));
  const cv::Vec3f trunk(40, 60, 85);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x) {
      const float u = (static_cast<float>(x) / side - 0.5f) * 2.0f;  // -1..1
      const float h = 1.0f - static_cast<float>(y) / side;          // 0 bottom .. 1 top
      // crown: ellipse centred at 0.62 height
      const float ex = u / 0.95f, ey = (h - 0.62f) / 0.38f;
      const float r = std::sqrt(ex * ex + ey * ey) + 0.35f * blob(y, x);
      if (r < 0.9f && leaves(y, x) > -0.55f) {
        const float shade = 0.45f * leaves(y, x) + 0.25f * (0.62f - h);
        put(out, y, x, p.color * (1.0f - 0.25f * std::max(0.0f, -ey)), shade);
      } else if (h < 0.45f && std::abs(u) < 0.07f + 0.03f * (0.45f - h)) {
        put(out, y, x, trunk, 0.3f * leaves(y, x));
      }
    }
  return out;
}

int pow2_floor(int v) {
  int p = 1;
  while (p * 2 <= v) p *= 2;
  return p;
}

}  // namespace

void build_mips(Texture& texture) {
  CV_Assert(!texture.levels.empty());
  texture.levels.resize(1);
  const int side = texture.levels[0].cols;
  texture.size_log2 = 0;
  while ((1 << texture.size_log2) < side) ++texture.size_log2;
  cv::Mat current = texture.levels[0];
  while (current.cols > 1) {
    cv::Mat next(current.rows / 2, current.cols / 2, CV_8UC4);
    for (int y = 0; y < next.rows; ++y)
      for (int x = 0; x < next.cols; ++x) {
        const cv::Vec4b& a = current.at<cv::Vec4b>(2 * y, 2 * x);
        const cv::Vec4b& b = current.at<cv::Vec4b>(2 * y, 2 * x + 1);
        const cv::Vec4b& c = current.at<cv::Vec4b>(2 * y + 1, 2 * x);
        const cv::Vec4b& d = current.at<cv::Vec4b>(2 * y + 1, 2 * x + 1);
        cv::Vec4b& o = next.at<cv::Vec4b>(y, x);
        for (int k = 0; k < 4; ++k) o[k] = static_cast<unsigned char>((a[k] + b[k] + c[k] + d[k] + 2) / 4);
      }
    texture.levels.push_back(next);
    current = next;
  }
}

Result<Texture> make_texture(const std::string& name, const ConfigNode& def, const std::string& base_dir) {
  VISNAV_TRY(check_keys(def,
                        {"image", "procedural", "size_m", "color", "color2", "contrast", "detail", "pixels", "seed",
                         "stretch", "seasons", "cell_m", "cell_h_m", "grout_m", "feature_m", "bay_m", "storey_m",
                         "window_w_m", "window_h_m", "sill_m"},
                        "texture '" + name + "'"));
  Texture tex;
  tex.name = name;
  VISNAV_ASSIGN(const double size_m, get_double(def, "size_m", 2.0, 0.05, 1000.0));
  VISNAV_ASSIGN(const double contrast, get_double(def, "contrast", 1.0, 0.0, 5.0));
  VISNAV_ASSIGN(const double seed, get_double(def, "seed", 1.0, 0.0, 1e9));
  VISNAV_ASSIGN(const double pixels, get_double(def, "pixels", 512.0, 16.0, 2048.0));
  std::vector<double> color{128, 128, 128};
  std::vector<double> color2{80, 80, 80};
  if (const ConfigNode* c = def.find("color")) { VISNAV_ASSIGN(color, as_numbers(*c, "color", 3)); }
  if (const ConfigNode* c = def.find("color2")) { VISNAV_ASSIGN(color2, as_numbers(*c, "color2", 3)); }
  for (double v : color) if (v < 0 || v > 255) return node_error(*def.find("color"), "key 'color': components must be in [0, 255]");
  for (double v : color2) if (v < 0 || v > 255) return node_error(*def.find("color2"), "key 'color2': components must be in [0, 255]");

  const ConfigNode* image = def.find("image");
  const ConfigNode* procedural = def.find("procedural");
  if ((image == nullptr) == (procedural == nullptr))
    return node_error(def, "texture '" + name + "': give exactly one of 'image' or 'procedural'");

  cv::Mat bgra;
  bool stretch_default = false;
  if (image != nullptr) {
    if (!image->is_scalar()) return node_error(*image, "key 'image': expected a file path");
    std::string path = image->scalar();
    if (path.rfind("skimage:", 0) == 0) {
      std::string file = path.substr(8);
      if (file.find('.') == std::string::npos) file += ".png";
      path = (fs::path(skimage_data_dir()) / file).string();
    } else if (fs::path(path).is_relative()) {
      path = (fs::path(base_dir) / path).string();
    }
    std::error_code ec;
    if (!fs::is_regular_file(path, ec))
      return node_error(*image, "texture '" + name + "': image file '" + image->scalar() + "' not found (looked at " + path + ")");
    if (auto checked = visnav::check_input_file(path, visnav::kMaxImageFileBytes, "texture image"); !checked)
      return node_error(*image, "texture '" + name + "': " + checked.error().message);
    cv::Mat loaded = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (loaded.empty()) return node_error(*image, "texture '" + name + "': cannot decode image '" + path + "'");
    if (loaded.depth() != CV_8U) loaded.convertTo(loaded, CV_8U, loaded.depth() == CV_16U ? 1.0 / 256 : 1.0);
    const int side = std::min(1024, pow2_floor(std::min(loaded.cols, loaded.rows)));
    // centre crop to a square, then resize to the power-of-two side
    const int sq = std::min(loaded.cols, loaded.rows);
    loaded = loaded(cv::Rect((loaded.cols - sq) / 2, (loaded.rows - sq) / 2, sq, sq));
    cv::Mat resized;
    cv::resize(loaded, resized, cv::Size(side, side), 0, 0, cv::INTER_AREA);
    bgra.create(side, side, CV_8UC4);
    const bool has_color_key = def.find("color") != nullptr;
    if (resized.channels() == 1) {
      const double mean = cv::mean(resized)[0];
      for (int y = 0; y < side; ++y)
        for (int x = 0; x < side; ++x) {
          const double g = resized.at<unsigned char>(y, x);
          const double shade = contrast * (g - mean) / 128.0;
          cv::Vec4b& p = bgra.at<cv::Vec4b>(y, x);
          for (int c = 0; c < 3; ++c)
            p[c] = cv::saturate_cast<unsigned char>(has_color_key ? color[2 - c] * (1.0 + shade) : g);
          p[3] = 255;
        }
    } else {
      cv::Mat src4;
      if (resized.channels() == 3) cv::cvtColor(resized, src4, cv::COLOR_BGR2BGRA);
      else src4 = resized;
      bgra = src4.clone();
      tex.has_alpha = resized.channels() == 4;
    }
  } else {
    if (!procedural->is_scalar()) return node_error(*procedural, "key 'procedural': expected a pattern name");
    const std::string kind = procedural->scalar();
    Proc p;
    p.side = pow2_floor(static_cast<int>(pixels));
    p.size_m = size_m;
    p.color = rgb_to_bgrf(color);
    p.color2 = rgb_to_bgrf(color2);
    VISNAV_ASSIGN(p.detail, get_double(def, "detail", 0.12, 0.0, 1.0));
    p.rng.seed(static_cast<unsigned>(seed));
    VISNAV_ASSIGN(const double cell_m, get_double(def, "cell_m", 0.5, 1e-3, 100.0));
    VISNAV_ASSIGN(const double cell_h_m, get_double(def, "cell_h_m", cell_m, 1e-3, 100.0));
    VISNAV_ASSIGN(const double grout_m, get_double(def, "grout_m", 0.01, 0.0, 10.0));
    VISNAV_ASSIGN(const double feature_m, get_double(def, "feature_m", 0.25, 1e-3, 100.0));
    if (kind == "noise") {
      bgra = make_noise(p, feature_m);
    } else if (kind == "tiles") {
      bgra = make_cells(p, cell_m, cell_h_m, grout_m, false);
    } else if (kind == "bricks") {
      bgra = make_cells(p, cell_m, cell_h_m, grout_m, true);
    } else if (kind == "planks") {
      bgra = make_planks(p, cell_m, grout_m);
    } else if (kind == "facade") {
      VISNAV_ASSIGN(const double bay_m, get_double(def, "bay_m", 2.0, 0.2, 100.0));
      VISNAV_ASSIGN(const double storey_m, get_double(def, "storey_m", 3.0, 0.5, 100.0));
      VISNAV_ASSIGN(const double ww, get_double(def, "window_w_m", 1.0, 0.05, 100.0));
      VISNAV_ASSIGN(const double wh, get_double(def, "window_h_m", 1.4, 0.05, 100.0));
      VISNAV_ASSIGN(const double sill, get_double(def, "sill_m", 0.9, 0.0, 100.0));
      if (ww >= bay_m || wh + sill >= storey_m)
        return node_error(def, "texture '" + name + "': windows must fit into a bay (window_w_m < bay_m, sill_m + window_h_m < storey_m)");
      bgra = make_facade(p, bay_m, storey_m, ww, wh, sill);
    } else if (kind == "tree") {
      bgra = make_tree(p);
      tex.has_alpha = true;
      stretch_default = true;
    } else {
      return node_error(*procedural, "texture '" + name + "': unknown procedural pattern '" + kind +
                                         "' (known: noise, tiles, bricks, planks, facade, tree)");
    }
  }
  VISNAV_ASSIGN(const bool stretch, get_bool(def, "stretch", stretch_default));
  tex.tiled = !stretch;
  tex.texel_m = size_m / bgra.cols;
  tex.levels.push_back(bgra);
  build_mips(tex);
  return tex;
}

}  // namespace visnav::sim::detail
