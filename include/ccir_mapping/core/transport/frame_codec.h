// Frames on a bridge link (TCP): a fixed 28-byte header, the payload, and an HMAC-SHA256 of both
// under the team key (the HELLO) or a key of the connection (every later frame: linkKey), so a
// peer without the key is refused at its first frame and frames recorded from another
// connection at their second. The decoder
// reads the byte stream, checks every size before allocating, and stops at the first frame it
// cannot trust: the link is then closed and the reason counted.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace ccir_mapping::core::transport {

enum class FrameType : std::uint8_t {
  kHello = 1,  // robot name: the first frame each side sends
  kTopic = 2,  // a topic's name, type, md5 and definition, once per topic and link
  kData = 3,   // (a fragment of) a serialised message
  kAck = 4,    // the highest reliable sequence received in order
};

struct Frame {
  FrameType type = FrameType::kData;
  std::uint8_t flags = 0;
  std::uint16_t topic = 0;
  std::uint64_t sequence = 0;
  std::uint16_t fragment = 0;
  std::uint16_t fragments = 1;
  std::vector<std::uint8_t> payload;

  bool operator==(const Frame& other) const;
};

constexpr std::size_t kFrameHeaderBytes = 28;
constexpr std::size_t kFrameMacBytes = 32;
/// Bytes a frame with `payload_bytes` of payload takes on the wire.
constexpr std::size_t wireBytes(std::size_t payload_bytes) {
  return kFrameHeaderBytes + payload_bytes + kFrameMacBytes;
}

enum class FrameError {
  kNone,
  kBadMagic,
  kBadVersion,
  kUnknownType,
  kTooLarge,
  kBadFragment,
  kBadMac,
};
const char* toString(FrameError error);

/// Throws std::invalid_argument for a payload above 4 GiB or fragment >= fragments.
std::vector<std::uint8_t> encodeFrame(const Frame& frame, const std::string& key);

/// Bytes each side draws afresh for every connection and sends in its HELLO.
constexpr std::size_t kNonceBytes = 16;
using Nonce = std::array<std::uint8_t, kNonceBytes>;
/// A fresh nonce from OpenSSL's generator.
Nonce drawNonce();
/// The key of one direction of one connection: HMAC-SHA256 under the team key of both sides'
/// nonces, the sender's first. A frame recorded from another connection fails its MAC.
std::string linkKey(const std::string& team_key, const Nonce& sender, const Nonce& receiver);

class FrameDecoder {
 public:
  FrameDecoder(std::string key, std::size_t max_payload_bytes);

  void feed(const std::uint8_t* data, std::size_t size);
  /// The next complete frame, or nullopt when more bytes are needed or the stream failed.
  std::optional<Frame> next();
  /// The key of the frames after the one next() returned last.
  void setKey(std::string key) { key_ = std::move(key); }
  /// Why the stream failed (kNone while it is fine); once failed it stays failed.
  FrameError error() const { return error_; }
  /// Bytes received and not yet decoded.
  std::size_t buffered() const { return buffer_.size() - offset_; }

 private:
  std::string key_;
  std::size_t max_payload_bytes_;
  std::vector<std::uint8_t> buffer_;
  std::size_t offset_ = 0;
  FrameError error_ = FrameError::kNone;
};

}  // namespace ccir_mapping::core::transport
