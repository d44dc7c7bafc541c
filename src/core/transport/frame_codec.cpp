#include "ccir_mapping/core/transport/frame_codec.h"

#include <algorithm>
#include <stdexcept>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>

namespace ccir_mapping::core::transport {
namespace {

constexpr std::uint8_t kMagic[4] = {'C', 'C', 'I', 'R'};
// 2: HELLO carries a nonce and later frames are keyed by the connection (linkKey).
constexpr std::uint8_t kVersion = 2;

void put(std::vector<std::uint8_t>& out, std::uint64_t value, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<std::uint8_t>(value >> (8 * i)));
}

std::uint64_t get(const std::uint8_t* in, int bytes) {
  std::uint64_t value = 0;
  for (int i = 0; i < bytes; ++i) value |= static_cast<std::uint64_t>(in[i]) << (8 * i);
  return value;
}

void mac(const std::string& key, const std::uint8_t* data, std::size_t size,
         std::uint8_t out[kFrameMacBytes]) {
  unsigned int length = 0;
  HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), data, size, out, &length);
}

}  // namespace

Nonce drawNonce() {
  Nonce nonce;
  if (RAND_bytes(nonce.data(), static_cast<int>(nonce.size())) != 1) {
    throw std::runtime_error("OpenSSL could not draw a nonce");
  }
  return nonce;
}

std::string linkKey(const std::string& team_key, const Nonce& sender, const Nonce& receiver) {
  std::uint8_t both[2 * kNonceBytes];
  std::copy(sender.begin(), sender.end(), both);
  std::copy(receiver.begin(), receiver.end(), both + kNonceBytes);
  std::uint8_t key[kFrameMacBytes];
  mac(team_key, both, sizeof(both), key);
  return std::string(reinterpret_cast<const char*>(key), kFrameMacBytes);
}

bool Frame::operator==(const Frame& o) const {
  return type == o.type && flags == o.flags && topic == o.topic && sequence == o.sequence &&
         fragment == o.fragment && fragments == o.fragments && payload == o.payload;
}

const char* toString(FrameError error) {
  switch (error) {
    case FrameError::kNone:
      return "none";
    case FrameError::kBadMagic:
      return "bad magic";
    case FrameError::kBadVersion:
      return "bad version";
    case FrameError::kUnknownType:
      return "unknown type";
    case FrameError::kTooLarge:
      return "too large";
    case FrameError::kBadFragment:
      return "bad fragment";
    case FrameError::kBadMac:
      return "bad mac";
  }
  return "?";
}

std::vector<std::uint8_t> encodeFrame(const Frame& frame, const std::string& key) {
  if (frame.payload.size() > 0xffffffffULL || frame.fragment >= frame.fragments) {
    throw std::invalid_argument("encodeFrame: payload above 4 GiB or fragment out of range");
  }
  std::vector<std::uint8_t> out(kMagic, kMagic + 4);
  out.reserve(wireBytes(frame.payload.size()));
  put(out, kVersion, 1);
  put(out, static_cast<std::uint8_t>(frame.type), 1);
  put(out, frame.flags, 1);
  put(out, 0, 1);
  put(out, frame.topic, 2);
  put(out, frame.fragment, 2);
  put(out, frame.fragments, 2);
  put(out, 0, 2);
  put(out, frame.sequence, 8);
  put(out, frame.payload.size(), 4);
  out.insert(out.end(), frame.payload.begin(), frame.payload.end());
  std::uint8_t digest[kFrameMacBytes];
  mac(key, out.data(), out.size(), digest);
  out.insert(out.end(), digest, digest + kFrameMacBytes);
  return out;
}

FrameDecoder::FrameDecoder(std::string key, std::size_t max_payload_bytes)
    : key_(std::move(key)), max_payload_bytes_(max_payload_bytes) {}

void FrameDecoder::feed(const std::uint8_t* data, std::size_t size) {
  if (error_ != FrameError::kNone) return;
  // Drop what was decoded before growing the buffer.
  if (offset_ > 0 && offset_ >= buffer_.size() / 2) {
    buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(offset_));
    offset_ = 0;
  }
  buffer_.insert(buffer_.end(), data, data + size);
}

std::optional<Frame> FrameDecoder::next() {
  if (error_ != FrameError::kNone || buffered() < kFrameHeaderBytes) return std::nullopt;
  const std::uint8_t* h = buffer_.data() + offset_;
  auto fail = [this](FrameError e) {
    error_ = e;
    return std::nullopt;
  };
  // Judge the header before waiting for (or allocating) the payload it announces.
  for (int i = 0; i < 4; ++i) {
    if (h[i] != kMagic[i]) return fail(FrameError::kBadMagic);
  }
  if (h[4] != kVersion) return fail(FrameError::kBadVersion);
  if (h[5] < static_cast<std::uint8_t>(FrameType::kHello) ||
      h[5] > static_cast<std::uint8_t>(FrameType::kAck)) {
    return fail(FrameError::kUnknownType);
  }
  const std::uint64_t length = get(h + 24, 4);
  if (length > max_payload_bytes_) return fail(FrameError::kTooLarge);
  Frame frame;
  frame.fragment = static_cast<std::uint16_t>(get(h + 10, 2));
  frame.fragments = static_cast<std::uint16_t>(get(h + 12, 2));
  if (frame.fragments == 0 || frame.fragment >= frame.fragments) {
    return fail(FrameError::kBadFragment);
  }
  const std::size_t total = wireBytes(length);
  if (buffered() < total) return std::nullopt;
  std::uint8_t digest[kFrameMacBytes];
  mac(key_, h, kFrameHeaderBytes + length, digest);
  if (CRYPTO_memcmp(digest, h + kFrameHeaderBytes + length, kFrameMacBytes) != 0) {
    return fail(FrameError::kBadMac);
  }
  frame.type = static_cast<FrameType>(h[5]);
  frame.flags = h[6];
  frame.topic = static_cast<std::uint16_t>(get(h + 8, 2));
  frame.sequence = get(h + 16, 8);
  frame.payload.assign(h + kFrameHeaderBytes, h + kFrameHeaderBytes + length);
  offset_ += total;
  return frame;
}

}  // namespace ccir_mapping::core::transport
