// bench_alignment: error of the EM team-frame estimate against the fraction of false
// candidates (0 to 99 %), on synthetic two-robot data (20 true loops, sigma 0.1 m / 1 deg).
// Prints JSON; --png FILE also draws the curve.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <boost/program_options.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "ccir_mapping/core/testing/synthetic_candidates.h"
#include "command_line.h"

namespace po = boost::program_options;
namespace alignment = ccir_mapping::core::alignment;
namespace testing = ccir_mapping::core::testing;
namespace tools = ccir_mapping::tools;

namespace {

struct Point {
  double ratio;
  int outliers;
  double found_fraction;
  double median_translation_m;
  double worst_translation_m;
  double worst_rotation_deg;
  double ms;
};

void draw(const std::vector<Point>& points, const std::string& path) {
  const int w = 900;
  const int h = 500;
  const int left = 80;
  const int bottom = 60;
  cv::Mat image(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  const double y_max = 0.2;  // m
  auto x_of = [&](std::size_t i) {
    return left + static_cast<int>((w - left - 30) * double(i) / (points.size() - 1));
  };
  auto y_of = [&](double metres) {
    return h - bottom - static_cast<int>((h - bottom - 40) * std::min(metres, y_max) / y_max);
  };
  cv::line(image, {left, h - bottom}, {w - 20, h - bottom}, cv::Scalar(0, 0, 0));
  cv::line(image, {left, 30}, {left, h - bottom}, cv::Scalar(0, 0, 0));
  for (double tick = 0.0; tick <= y_max + 1e-9; tick += 0.05) {
    cv::putText(image, cv::format("%.2f", tick), {15, y_of(tick) + 5}, cv::FONT_HERSHEY_SIMPLEX,
                0.45, cv::Scalar(0, 0, 0));
    cv::line(image, {left - 5, y_of(tick)}, {left, y_of(tick)}, cv::Scalar(0, 0, 0));
  }
  cv::line(image, {left, y_of(0.1)}, {w - 20, y_of(0.1)}, cv::Scalar(0, 0, 200), 1, cv::LINE_AA);
  for (std::size_t i = 0; i < points.size(); ++i) {
    cv::putText(image, cv::format("%.0f", 100 * points[i].ratio), {x_of(i) - 10, h - bottom + 20},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
    cv::circle(image, {x_of(i), y_of(points[i].worst_translation_m)}, 4, cv::Scalar(200, 80, 0),
               cv::FILLED);
    cv::circle(image, {x_of(i), y_of(points[i].median_translation_m)}, 4, cv::Scalar(0, 150, 0),
               cv::FILLED);
    if (i > 0) {
      cv::line(image, {x_of(i - 1), y_of(points[i - 1].median_translation_m)},
               {x_of(i), y_of(points[i].median_translation_m)}, cv::Scalar(0, 150, 0), 2,
               cv::LINE_AA);
    }
  }
  cv::putText(image, "false candidates (%)", {w / 2 - 80, h - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.55,
              cv::Scalar(0, 0, 0));
  cv::putText(image,
              "team transform error (m): median (green), worst (blue) of the seeds; red: 0.1 m",
              {left, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  cv::imwrite(path, image);
}

struct Options {
  std::string png;
  int seeds = 5;
  int inliers = 20;
};

/// The options, or the exit code to end with (help, a usage error).
std::optional<int> parse(int argc, char** argv, Options* o) {
  po::options_description options(
      "Usage: bench_alignment [--png FILE] [--seeds N] [--inliers N]\nPrints JSON.\n\nOptions");
  options.add_options()("help,h", "print this help and exit")(
      "png", po::value<std::string>(&o->png), "also draw the curve into this PNG")(
      "seeds", po::value<int>(&o->seeds)->default_value(o->seeds), "runs per outlier ratio")(
      "inliers", po::value<int>(&o->inliers)->default_value(o->inliers), "true candidates per run");
  if (const auto exit_code = tools::parseCommandLine("bench_alignment", options, argc, argv)) {
    return exit_code;
  }
  if (o->seeds < 1 || o->inliers < 1) {
    return tools::usageError("bench_alignment", "--seeds and --inliers must be >= 1");
  }
  return std::nullopt;
}

/// The curve: for each outlier ratio, how often and how well the EM found the transform.
std::vector<Point> run(const Options& o) {
  std::vector<Point> points;
  for (double ratio : {0.0, 0.2, 0.4, 0.6, 0.8, 0.9, 0.95, 0.98, 0.99}) {
    const int outliers = static_cast<int>(std::lround(o.inliers * ratio / (1.0 - ratio)));
    std::vector<double> translation;
    double worst_rotation = 0.0;
    int found = 0;
    const auto start = std::chrono::steady_clock::now();
    for (int seed = 1; seed <= o.seeds; ++seed) {
      testing::SyntheticSpec spec;
      spec.inliers = o.inliers;
      spec.outliers = outliers;
      spec.seed = static_cast<unsigned>(seed);
      const auto s = testing::makeSyntheticCandidates(spec);
      const auto result =
          alignment::estimateFrameTransform(s.candidates, alignment::AlignmentParams{});
      if (!result.found) {
        translation.push_back(1e9);
        continue;
      }
      ++found;
      const auto d = s.truth.inverse() * result.transform;
      translation.push_back(d.translation().norm());
      worst_rotation = std::max(worst_rotation, Eigen::AngleAxisd(d.linear()).angle() * 180 / M_PI);
    }
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
            .count() /
        o.seeds;
    std::sort(translation.begin(), translation.end());
    points.push_back({ratio, outliers, double(found) / o.seeds, translation[translation.size() / 2],
                      translation.back(), worst_rotation, ms});
  }
  return points;
}

void report(const Options& o, const std::vector<Point>& points) {
  std::printf(
      "{\n  \"benchmark\": \"alignment\",\n  \"inliers\": %d,\n  \"seeds\": %d,\n"
      "  \"noise\": {\"translation_m\": 0.1, \"rotation_deg\": 1.0},\n  \"curve\": [\n",
      o.inliers, o.seeds);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Point& p = points[i];
    std::printf(
        "    {\"outlier_ratio\": %.2f, \"outliers\": %d, \"found\": %.2f, "
        "\"median_translation_error_m\": %.4f, \"worst_translation_error_m\": %.4g, "
        "\"worst_rotation_error_deg\": %.3f, \"ms_per_estimate\": %.1f}%s\n",
        p.ratio, p.outliers, p.found_fraction, p.median_translation_m, p.worst_translation_m,
        p.worst_rotation_deg, p.ms, i + 1 < points.size() ? "," : "");
  }
  std::printf("  ]\n}\n");
  if (!o.png.empty()) draw(points, o.png);
}

}  // namespace

int main(int argc, char** argv) {
  return tools::runTool("bench_alignment", argc, argv, parse, run, report);
}
