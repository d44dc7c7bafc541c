#include "ccir_mapping/core/routing/scan_codec.h"

#include <algorithm>
#include <cmath>

#include "ccir_mapping/core/common/compression.h"

namespace ccir_mapping::core::routing {

namespace {

constexpr std::uint8_t kVersion = 1;
constexpr double kMaxAbsM = 1e6;
// The same bound in position steps (1 mm).
constexpr std::int64_t kMaxAbsSteps = 1000000000;
/// Bytes of one point: up to three varints of 5 bytes, three normals and an intensity.
constexpr std::size_t kMaxPointBytes = 3 * 5 + 4;

void putVarint(std::uint64_t value, std::vector<std::uint8_t>* out) {
  while (value >= 0x80) {
    out->push_back(static_cast<std::uint8_t>(value | 0x80));
    value >>= 7;
  }
  out->push_back(static_cast<std::uint8_t>(value));
}

std::uint64_t zigzag(std::int64_t v) {
  return (static_cast<std::uint64_t>(v) << 1) ^ static_cast<std::uint64_t>(v >> 63);
}
std::int64_t unzigzag(std::uint64_t v) {
  return static_cast<std::int64_t>(v >> 1) ^ -static_cast<std::int64_t>(v & 1);
}

struct Reader {
  const std::vector<std::uint8_t>& bytes;
  std::size_t at = 0;
  bool ok = true;

  std::uint64_t varint() {
    std::uint64_t value = 0;
    for (int shift = 0; shift < 64; shift += 7) {
      if (at >= bytes.size()) break;
      const std::uint8_t b = bytes[at++];
      value |= static_cast<std::uint64_t>(b & 0x7f) << shift;
      if (!(b & 0x80)) return value;
    }
    ok = false;
    return 0;
  }
  const std::uint8_t* take(std::size_t n) {
    if (!ok || bytes.size() - at < n) {
      ok = false;
      return nullptr;
    }
    const std::uint8_t* p = bytes.data() + at;
    at += n;
    return p;
  }
};

std::int8_t quantiseNormal(float n) {
  return static_cast<std::int8_t>(std::clamp(std::lround(n * 127.0f), -127L, 127L));
}

template <class T>
std::optional<T> fail(std::string* error, const std::string& why) {
  if (error) *error = why;
  return std::nullopt;
}

}  // namespace

std::optional<std::vector<std::uint8_t>> encodeScan(const std::vector<ScanPoint>& points,
                                                    std::string* error) {
  std::vector<std::uint8_t> raw;
  raw.reserve(1 + 10 + points.size() * 10);
  raw.push_back(kVersion);
  putVarint(points.size(), &raw);
  std::int64_t previous[3] = {0, 0, 0};
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ScanPoint& p = points[i];
    const float values[] = {p.x, p.y, p.z, p.normal_x, p.normal_y, p.normal_z, p.intensity};
    for (std::size_t v = 0; v < 7; ++v) {
      if (!std::isfinite(values[v]) || std::abs(values[v]) > kMaxAbsM) {
        return fail<std::vector<std::uint8_t>>(
            error, "point " + std::to_string(i) + " has a non-finite or out-of-range value");
      }
    }
    for (int a = 0; a < 3; ++a) {
      const std::int64_t q = std::llround(values[a] / kScanPositionStepM);
      putVarint(zigzag(q - previous[a]), &raw);
      previous[a] = q;
    }
  }
  for (int a = 0; a < 3; ++a) {
    for (const ScanPoint& p : points) {
      const float n = a == 0 ? p.normal_x : a == 1 ? p.normal_y : p.normal_z;
      raw.push_back(static_cast<std::uint8_t>(quantiseNormal(n)));
    }
  }
  for (const ScanPoint& p : points) {
    raw.push_back(static_cast<std::uint8_t>(std::clamp(std::lround(p.intensity), 0L, 255L)));
  }
  auto compressed = compress(raw);
  if (compressed.empty()) return fail<std::vector<std::uint8_t>>(error, "zstd failed");
  return compressed;
}

std::optional<std::vector<ScanPoint>> decodeScan(const std::vector<std::uint8_t>& bytes,
                                                 std::size_t max_points, std::string* error) {
  const auto raw = decompress(bytes, 1 + 10 + max_points * kMaxPointBytes);
  if (!raw) return fail<std::vector<ScanPoint>>(error, "not one zstd frame of the allowed size");
  Reader in{*raw};
  const std::uint8_t* version = in.take(1);
  if (!version || *version != kVersion) {
    return fail<std::vector<ScanPoint>>(error, "unknown encoding version");
  }
  const std::uint64_t count = in.varint();
  if (!in.ok || count > max_points) {
    return fail<std::vector<ScanPoint>>(
        error, "point count missing or above " + std::to_string(max_points));
  }
  std::vector<ScanPoint> points(count);
  std::int64_t position[3] = {0, 0, 0};
  for (ScanPoint& p : points) {
    float* xyz[] = {&p.x, &p.y, &p.z};
    for (int a = 0; a < 3; ++a) {
      // Steps between coordinates the encoder allows: anything else is refused before it can
      // overflow the sum (found by fuzz_scan_decoding).
      const std::int64_t step = unzigzag(in.varint());
      if (step > 2 * kMaxAbsSteps || step < -2 * kMaxAbsSteps ||
          std::abs(position[a] + step) > kMaxAbsSteps) {
        return fail<std::vector<ScanPoint>>(error, "a position beyond 1000 km");
      }
      position[a] += step;
      *xyz[a] = static_cast<float>(position[a] * kScanPositionStepM);
    }
    if (!in.ok) return fail<std::vector<ScanPoint>>(error, "truncated positions");
  }
  for (int a = 0; a < 3; ++a) {
    const std::uint8_t* plane = in.take(count);
    if (!plane) return fail<std::vector<ScanPoint>>(error, "truncated normals");
    for (std::size_t i = 0; i < count; ++i) {
      const float n = static_cast<std::int8_t>(plane[i]) / 127.0f;
      (a == 0 ? points[i].normal_x : a == 1 ? points[i].normal_y : points[i].normal_z) = n;
    }
  }
  for (ScanPoint& p : points) {  // back to unit length (a zero normal stays zero)
    const float norm =
        std::sqrt(p.normal_x * p.normal_x + p.normal_y * p.normal_y + p.normal_z * p.normal_z);
    if (norm > 0) {
      p.normal_x /= norm;
      p.normal_y /= norm;
      p.normal_z /= norm;
    }
  }
  const std::uint8_t* intensity = in.take(count);
  if (!intensity) return fail<std::vector<ScanPoint>>(error, "truncated intensities");
  for (std::size_t i = 0; i < count; ++i) points[i].intensity = intensity[i];
  if (in.at != raw->size()) return fail<std::vector<ScanPoint>>(error, "trailing bytes");
  return points;
}

}  // namespace ccir_mapping::core::routing
