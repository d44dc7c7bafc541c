// Writes the fuzz targets' seed corpus (scripts/fuzz runs it before fuzzing): a few valid inputs
// per target, made by the encoders the targets' decoders invert, so that the fuzzer starts from
// well-formed data. With a Velodyne capture, also its first packets as the pcap seed.
//   make_fuzz_seeds OUT_DIR [VLP16_PCAP]
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <vector>

#include "ccir_mapping/core/hgmm/gaussian_mixture.h"
#include "ccir_mapping/core/hgmm/mixture_codec.h"
#include "ccir_mapping/core/place_recognition/place_model.h"
#include "ccir_mapping/core/place_recognition/vocabulary.h"
#include "ccir_mapping/core/routing/scan_codec.h"

namespace fs = std::filesystem;
namespace core = ccir_mapping::core;

namespace {

void write(const fs::path& file, const std::vector<std::uint8_t>& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

void write(const fs::path& file, const std::string& text) {
  write(file, std::vector<std::uint8_t>(text.begin(), text.end()));
}

/// fuzz_scan_decoding's input: the encoding's bytes, then what FuzzedDataProvider reads from the
/// end (seed, max_points, count, encoding flag; multi-byte values low byte first).
std::string readText(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// FuzzedDataProvider's ConsumeRandomLengthString: each backslash doubled, ended by a backslash and
/// a character other than a backslash.
std::string randomLengthString(const std::string& text) {
  std::string out;
  for (const char c : text) out += c == '\\' ? std::string(2, c) : std::string(1, c);
  return out + "\\ ";
}

std::vector<std::uint8_t> scanInput(std::vector<std::uint8_t> bytes, bool gmm,
                                    std::uint16_t count) {
  for (int i = 0; i < 8; ++i) bytes.push_back(std::uint8_t(i));  // seed
  const std::uint16_t max_points = 4000;
  bytes.push_back(std::uint8_t(max_points & 0xff));
  bytes.push_back(std::uint8_t(max_points >> 8));
  bytes.push_back(std::uint8_t(count & 0xff));
  bytes.push_back(std::uint8_t(count >> 8));
  bytes.push_back(gmm ? 1 : 0);
  return bytes;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: make_fuzz_seeds OUT_DIR [VLP16_PCAP]\n";
    return 2;
  }
  const fs::path out = argv[1];
  // Frame stream: the honest start alone, and a few operations.
  write(out / "frame_stream" / "empty", std::vector<std::uint8_t>{});
  write(out / "frame_stream" / "operations",
        std::vector<std::uint8_t>{0, 1, 2, 3, 4, 1, 0, 1, 3, 3, 1, 2, 0, 4, 4, 1});
  // Broker: its input picks operations and their fields (FuzzedDataProvider), so any bytes make
  // a session; a few drawn ones of a period's length start it off.
  std::mt19937 draw(7);
  for (const std::size_t length : {64, 512, 4096}) {
    std::vector<std::uint8_t> bytes(length);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(draw());
    write(out / "broker" / ("drawn_" + std::to_string(length)), bytes);
  }
  // Clouds: the layout too is drawn from the input, so drawn bytes make clouds.
  for (const std::size_t length : {32, 256, 2048}) {
    std::vector<std::uint8_t> bytes(length);
    for (auto& b : bytes) b = static_cast<std::uint8_t>(draw());
    write(out / "cloud_conversion" / ("drawn_" + std::to_string(length)), bytes);
  }
  // Scans: 40 points on a wall, as points and as a two-Gaussian mixture.
  std::vector<core::routing::ScanPoint> points;
  for (int i = 0; i < 40; ++i) points.push_back({float(i % 8), 3.0f, float(i / 8), 0, -1, 0, 9});
  write(out / "scan_decoding" / "cloud", scanInput(*core::routing::encodeScan(points), false, 40));
  core::hgmm::Gaussian a, b;
  a.weight = b.weight = 0.5;
  a.mean << 1, 3, 1;
  b.mean << 5, 3, 1;
  a.covariance = b.covariance = Eigen::Vector3d(1.0, 1e-4, 0.5).asDiagonal();
  write(out / "scan_decoding" / "gmm",
        scanInput(core::hgmm::encodeMixture(core::hgmm::GaussianMixture({a, b})), true, 40));
  // g2o: a 2D and a 3D graph with an odometry and a switchable loop edge.
  write(out / "g2o_reader" / "se2.g2o",
        "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0.1\nVERTEX_SE2 2 2 0 0.2\n"
        "EDGE_SE2 0 1 1 0 0.1 100 0 0 100 0 400\nEDGE_SE2 1 2 1 0 0.1 100 0 0 100 0 400\n"
        "EDGE_SE2_SWITCHABLE 0 2 2 0 0.2 100 0 0 100 0 400\nFIX 0\n");
  write(out / "g2o_reader" / "se3.g2o",
        "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1 0 0 0 0 0 1\n"
        "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 400 0 0 400 0 400\n");
  // Vocabulary: three words.
  std::vector<core::features::SpinImage> words(3);
  for (std::size_t w = 0; w < words.size(); ++w) words[w].fill(float(w) / 3.0f);
  const fs::path vocabulary = out / "vocabulary" / "three_words.bin";
  fs::create_directories(vocabulary.parent_path());
  core::place_recognition::Vocabulary(words).save(vocabulary.string());
  // Place model: the files train_place_model writes for that vocabulary (fuzz_place_model
  // keeps the vocabulary and reads the tree, the samples and model.yaml from its input).
  const std::vector<core::place_recognition::WordSet> samples{{0, 1}, {1, 2}, {0}, {0, 1, 2}};
  core::place_recognition::Vocabulary three(words);
  auto tree = core::place_recognition::ChowLiuTree::learn(samples, three.size());
  const fs::path model_dir = out / "place_model_files";
  core::place_recognition::PlaceModel{std::move(three), std::move(tree), samples, {}}.save(
      model_dir.string(), "");
  write(out / "place_model" / "trained",
        randomLengthString(readText(model_dir / "chow_liu_tree.txt")) +
            randomLengthString(readText(model_dir / "samples.txt")) +
            readText(model_dir / "model.yaml"));
  fs::remove_all(model_dir);
  // pcap: the global header and the first 12 records (~15 KB: a slice of a rotation).
  if (argc > 2) {
    std::ifstream in(argv[2], std::ios::binary);
    std::vector<std::uint8_t> head(24);
    in.read(reinterpret_cast<char*>(head.data()), 24);
    for (int record = 0; record < 12 && in; ++record) {
      std::vector<std::uint8_t> header(16);
      if (!in.read(reinterpret_cast<char*>(header.data()), 16)) break;
      const std::uint32_t length = header[8] | header[9] << 8 | header[10] << 16 | header[11] << 24;
      std::vector<std::uint8_t> body(length);
      if (length > 65536 || !in.read(reinterpret_cast<char*>(body.data()), length)) break;
      head.insert(head.end(), header.begin(), header.end());
      head.insert(head.end(), body.begin(), body.end());
    }
    write(out / "pcap_reader" / "vlp16_start.pcap", head);
  } else {
    write(out / "pcap_reader" / "empty.pcap", std::vector<std::uint8_t>{});
  }
  return 0;
}
