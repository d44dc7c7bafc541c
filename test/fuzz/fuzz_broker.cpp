// libFuzzer target: the CCIR broker's handling of what teammates send it (offers, requests,
// receipts, scans) interleaved with its own keyframes, link states, team transforms and offer
// periods, all drawn from the input: poses and scores may be NaN or huge, names strangers,
// ids anything. Beyond no crash, what it promises is checked: it sends a teammate only kept
// keyframes offered to it, offers only kept keyframes, requests only what a teammate offered
// and acknowledges only scans it received.
#include <fuzzer/FuzzedDataProvider.h>

#include <cstdint>
#include <cstdlib>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ccir_mapping/core/routing/ccir_broker.h"

namespace {

using ccir_mapping::core::KeyframeId;
using ccir_mapping::core::Pose3;
using ccir_mapping::core::Stamp;
using namespace ccir_mapping::core::routing;

const std::vector<std::string> kNames = {"robot_b", "robot_c", "robot_a", "stranger", ""};

void check(bool promise) {
  if (!promise) std::abort();  // a broken promise is a finding like a crash
}

double anyDouble(FuzzedDataProvider& in) {
  switch (in.ConsumeIntegralInRange(0, 7)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return -1e300;
    default:
      return in.ConsumeFloatingPointInRange(-1e4, 1e4);
  }
}

Pose3 anyPose(FuzzedDataProvider& in) {
  Pose3 pose = Pose3::Identity();
  pose.translation() = Eigen::Vector3d(anyDouble(in), anyDouble(in), anyDouble(in));
  pose.linear() = Eigen::AngleAxisd(anyDouble(in), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

const std::string& anyName(FuzzedDataProvider& in) {
  return kNames[in.ConsumeIntegralInRange<std::size_t>(0, kNames.size() - 1)];
}

KeyframeId anyId(FuzzedDataProvider& in) {
  return in.ConsumeBool() ? in.ConsumeIntegralInRange<KeyframeId>(0, 40)
                          : in.ConsumeIntegral<KeyframeId>();
}

std::vector<ccir_mapping::core::information::VoxelGain> anyFootprint(FuzzedDataProvider& in) {
  std::vector<ccir_mapping::core::information::VoxelGain> footprint(
      in.ConsumeIntegralInRange(0, 20));
  for (auto& [key, gain] : footprint) {
    for (int i = 0; i < 3; ++i) key[i] = in.ConsumeIntegralInRange<std::uint16_t>(32760, 32776);
    gain = static_cast<float>(anyDouble(in));
  }
  return footprint;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider in(data, size);
  BrokerParams params;
  params.max_kept_scans = 8;
  params.max_offer_scans = 10;
  params.min_novelty = in.ConsumeBool() ? 0.0 : 0.25;
  CcirBroker broker("robot_a", {"robot_b", "robot_c"}, params);
  std::set<KeyframeId> kept;
  std::map<std::string, std::set<KeyframeId>> offered_to;  // what our offers named
  std::map<std::string, std::set<KeyframeId>> received_from;
  std::map<std::string, std::set<KeyframeId>> offered_by;  // what teammates' offers named
  KeyframeId next_id = 1;
  double now_s = 0.0;
  while (in.remaining_bytes() > 0) {
    switch (in.ConsumeIntegralInRange(0, 9)) {
      case 0: {
        Offer offer{anyName(in), anyName(in), in.ConsumeIntegral<std::uint32_t>(), {}};
        offer.scans.resize(in.ConsumeIntegralInRange(0, 12));
        for (auto& s : offer.scans) {
          s = {anyId(in), anyPose(in), in.ConsumeIntegral<int>(), in.ConsumeIntegral<std::size_t>(),
               anyDouble(in)};
        }
        if (broker.onOffer(offer)) {
          for (const auto& s : offer.scans) offered_by[offer.provider].insert(s.id);
        }
        break;
      }
      case 1: {
        Request request{
            anyName(in), anyName(in), in.ConsumeIntegralInRange<std::uint32_t>(0, 5), {}};
        request.ids.resize(in.ConsumeIntegralInRange(0, 12));
        for (auto& id : request.ids) id = anyId(in);
        for (const KeyframeId id : broker.onRequest(request, now_s).send) {
          check(kept.count(id) && offered_to[request.requester].count(id));
        }
        break;
      }
      case 2: {
        Receipt receipt{anyName(in), anyName(in), {}};
        receipt.ids.resize(in.ConsumeIntegralInRange(0, 12));
        for (auto& id : receipt.ids) id = anyId(in);
        broker.onReceipt(receipt);
        break;
      }
      case 3: {
        const std::string& provider = anyName(in);
        const KeyframeId id = anyId(in);
        if (broker.onScanReceived(provider, id, in.ConsumeIntegral<std::size_t>())) {
          received_from[provider].insert(id);
        }
        break;
      }
      case 4: {
        LinkState link{in.ConsumeBool(),
                       anyDouble(in),
                       anyDouble(in),
                       in.ConsumeIntegral<std::size_t>(),
                       in.ConsumeIntegral<std::size_t>(),
                       anyDouble(in)};
        const std::string& peer = anyName(in);
        if (peer == "robot_b" || peer == "robot_c") broker.setLink(peer, link);
        break;
      }
      case 5: {
        const std::string& peer = anyName(in);
        if (peer == "robot_b" || peer == "robot_c") {
          broker.setTeamTransform(
              peer, in.ConsumeBool() ? std::optional<Pose3>(anyPose(in)) : std::nullopt);
        }
        break;
      }
      case 6: {
        const KeyframeId id = next_id++;
        kept.insert(id);
        for (const KeyframeId gone : broker.addKeyframe(
                 id, in.ConsumeIntegral<std::int64_t>(), anyPose(in),
                 in.ConsumeIntegralInRange<std::size_t>(0, 1 << 20), anyFootprint(in))) {
          check(kept.erase(gone) == 1);
        }
        break;
      }
      case 7: {
        const KeyframeId id = anyId(in);
        broker.setUncertainty(id, anyDouble(in));
        broker.setCorrespondences(anyName(in), id, in.ConsumeIntegral<int>());
        break;
      }
      case 8: {
        std::vector<std::pair<Stamp, Pose3>> poses(in.ConsumeIntegralInRange(0, 4));
        for (auto& [stamp, pose] : poses) {
          stamp = in.ConsumeIntegral<std::int64_t>();
          pose = anyPose(in);
        }
        broker.setOptimizedPoses(poses);
        break;
      }
      case 9: {
        now_s += in.ConsumeFloatingPointInRange(0.0, 100.0);
        const double information = anyDouble(in);
        const auto period = broker.runPeriod([&](const Pose3&) { return information; }, now_s);
        for (const Offer& offer : period.offers) {
          check(offer.provider == "robot_a" && offer.scans.size() <= kept.size());
          for (const auto& s : offer.scans) {
            check(kept.count(s.id) == 1);
            offered_to[offer.requester].insert(s.id);
          }
        }
        for (const Request& request : period.requests) {
          for (const KeyframeId id : request.ids) check(offered_by[request.provider].count(id));
        }
        for (const Receipt& receipt : period.receipts) {
          for (const KeyframeId id : receipt.ids) check(received_from[receipt.provider].count(id));
        }
        break;
      }
    }
  }
  return 0;
}
