// CCIR's offers, requests, sends and receipts on small drawn worlds. Footprints are blocks along
// one corridor (x = block index); each drawing shows which blocks a keyframe sees:
//
//   blocks   0 ........ 9   20 ....... 29   40 .. 44
//   place      A (10)          B (10)         C (5)
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <string>
#include <type_traits>
#include <variant>
#include <vector>

#include "ccir_mapping/core/information/scan_ranker.h"
#include "ccir_mapping/core/routing/broker_stage.h"
#include "ccir_mapping/core/routing/ccir_broker.h"

namespace ccir_mapping::core::routing {
namespace {

using information::VoxelGain;

std::vector<VoxelGain> blocks(int first, int count, float gain = 1.0F) {
  std::vector<VoxelGain> result;
  for (int x = first; x < first + count; ++x) {
    result.push_back({octomap::OcTreeKey(static_cast<octomap::key_type>(x), 0, 0), gain});
  }
  return result;
}
const auto kPlaceA = [] { return blocks(0, 10); };
const auto kPlaceB = [] { return blocks(20, 10); };
const auto kPlaceC = [] { return blocks(40, 5); };

constexpr std::size_t kScanBytes = 50000;

LinkState link(double budget = 150000.0, std::size_t queued_bulk_bytes = 0,
               double tokens_bytes = 0.0, std::size_t queued_control_bytes = 0) {
  LinkState state;
  state.connected = true;
  state.budget_bytes_per_s = state.total_budget_bytes_per_s = budget;
  state.queued_bulk_bytes = queued_bulk_bytes;
  state.queued_control_bytes = queued_control_bytes;
  state.available_tokens_bytes = tokens_bytes;
  return state;
}

BrokerParams params(double lambda = 0.5) {
  BrokerParams p;
  p.loop_closure_weight = lambda;
  return p;
}

std::vector<KeyframeId> ids(const Offer& offer) {
  std::vector<KeyframeId> result;
  for (const auto& s : offer.scans) result.push_back(s.id);
  return result;
}

/// Robot a with one teammate b (the whole link budget goes to b).
struct Provider : ::testing::Test {
  CcirBroker a{"robot_a", {"robot_b"}, params()};
  void keyframe(KeyframeId id, std::vector<VoxelGain> footprint, std::size_t bytes = kScanBytes) {
    a.addKeyframe(id, Stamp(id), Pose3(Eigen::Translation3d(double(id), 0, 0)), bytes,
                  std::move(footprint));
  }
};

TEST_F(Provider, OfferHoldsAtMostWhatOnePeriodCarries) {
  for (KeyframeId id = 0; id < 10; ++id) keyframe(id, blocks(int(id) * 10, 10));
  EXPECT_FALSE(a.makeOffer("robot_b", 0.0)) << "no link state yet: nothing is offered";
  a.setLink("robot_b", link(150000.0));  // 150 KB per 1 s period / 50 KB a scan = 3
  const auto offer = a.makeOffer("robot_b", 0.0);
  ASSERT_TRUE(offer);
  EXPECT_EQ(offer->scans.size(), 3u);
  EXPECT_EQ(offer->provider, "robot_a");
  EXPECT_EQ(offer->requester, "robot_b");
  // A backlog on the link shrinks the next offer (control goes first, so it counts too); a
  // full queue stops offers; a full bucket lets the burst go at once.
  a.setLink("robot_b", link(150000.0, 60000));
  EXPECT_EQ(a.makeOffer("robot_b", 0.0)->scans.size(), 1u);
  a.setLink("robot_b", link(150000.0, 30000, 0.0, 30000));
  EXPECT_EQ(a.makeOffer("robot_b", 0.0)->scans.size(), 1u);
  a.setLink("robot_b", link(150000.0, 200000));
  EXPECT_FALSE(a.makeOffer("robot_b", 0.0));
  a.setLink("robot_b", link(150000.0, 0, 100000.0));  // 250 KB: 5 scans
  EXPECT_EQ(a.makeOffer("robot_b", 0.0)->scans.size(), 5u);
  auto down = link();
  down.connected = false;
  a.setLink("robot_b", down);
  EXPECT_FALSE(a.makeOffer("robot_b", 0.0)) << "link down";
}

// Found by fuzz_broker: a link state whose budget is beyond any count (or NaN) made the offer's
// size an out-of-range conversion.
TEST_F(Provider, ANonsenseLinkStateOffersAtMostEveryKeyframeOrNothing) {
  for (KeyframeId id = 0; id < 4; ++id) keyframe(id, blocks(int(id) * 10, 10));
  a.setLink("robot_b", link(1e300));
  const auto offer = a.makeOffer("robot_b", 0.0);
  ASSERT_TRUE(offer);
  EXPECT_EQ(offer->scans.size(), 4u);
  a.setLink("robot_b", link(std::numeric_limits<double>::quiet_NaN()));
  EXPECT_FALSE(a.makeOffer("robot_b", 0.0));
}

TEST(ProviderWithTwoPeers, ThePeersShareTheRadiosTotalBudget) {
  CcirBroker a("robot_a", {"robot_b", "robot_c"}, params());
  for (KeyframeId id = 0; id < 10; ++id) {
    a.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, blocks(int(id) * 10, 10));
  }
  // 150 KB/s per link, 150 KB/s in total: 75 KB a period each, one scan each; of a full
  // 130 KB bucket each gets half, 140 KB a period: two scans each.
  a.setLink("robot_b", link());
  a.setLink("robot_c", link());
  EXPECT_EQ(a.makeOffer("robot_b", 0.0)->scans.size(), 1u);
  EXPECT_EQ(a.makeOffer("robot_c", 0.0)->scans.size(), 1u);
  a.setLink("robot_b", link(150000.0, 0, 130000.0));
  a.setLink("robot_c", link(150000.0, 0, 130000.0));
  EXPECT_EQ(a.makeOffer("robot_b", 0.0)->scans.size(), 2u);
  EXPECT_EQ(a.makeOffer("robot_c", 0.0)->scans.size(), 2u);
}

TEST_F(Provider, OffersCarryOptimisedPosesAndNewKeyframesTheNewestCorrection) {
  keyframe(0, kPlaceA());  // odometry x = 0
  keyframe(1, kPlaceB());  // odometry x = 1
  // The Backend moved keyframe 1 by 0.5 m in y: keyframe 2 (odometry x = 2) lands there too.
  const Pose3 corrected(Eigen::Translation3d(1.0, 0.5, 0.0));
  a.setOptimizedPoses({{Stamp(0), Pose3::Identity()}, {Stamp(1), corrected}});
  EXPECT_TRUE(a.placeOwn(Pose3(Eigen::Translation3d(2, 0, 0)))
                  .isApprox(Pose3(Eigen::Translation3d(2, 0.5, 0))));
  keyframe(2, kPlaceC());
  a.setLink("robot_b", link());
  const auto offer = a.makeOffer("robot_b", 0.0);
  ASSERT_EQ(offer->scans.size(), 3u);
  for (const auto& scan : offer->scans) {
    EXPECT_NEAR(scan.pose.translation().y(), scan.id == 0 ? 0.0 : 0.5, 1e-12) << scan.id;
  }
}

TEST_F(Provider, RequestedScansAreSentOnceAndNeverOfferedAgain) {
  //   0: A   1: B   2: C
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceB());
  keyframe(2, kPlaceC());
  a.setLink("robot_b", link());
  const auto offer = a.makeOffer("robot_b", 0.0);
  ASSERT_TRUE(offer);
  ASSERT_EQ(ids(*offer), (std::vector<KeyframeId>{0, 1, 2}));  // information, ties by id
  const auto outcome = a.onRequest({"robot_b", "robot_a", offer->sequence, {1}}, 0.0);
  EXPECT_EQ(outcome.send, (std::vector<KeyframeId>{1}));
  EXPECT_TRUE(outcome.refused.empty());
  const auto again = a.onRequest({"robot_b", "robot_a", offer->sequence, {1, 2}}, 0.0);
  EXPECT_EQ(again.send, (std::vector<KeyframeId>{2}));
  EXPECT_EQ(again.refused.at("already_sent"), 1);
  a.setLink("robot_b", link());
  EXPECT_EQ(ids(*a.makeOffer("robot_b", 1.0)), (std::vector<KeyframeId>{0}));
  EXPECT_EQ(a.counters().at("robot_b").scans_sent, 2u);
  EXPECT_EQ(a.counters().at("robot_b").scan_bytes_sent, 2 * kScanBytes);
}

TEST_F(Provider, AfterASendTheNextOfferMovesElsewhere) {
  //   0: A   1: A again (the same blocks)   2: B, a little less to see
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceA());
  keyframe(2, blocks(20, 8));
  a.setLink("robot_b", link(50000.0));  // one scan a period
  const auto first = a.makeOffer("robot_b", 0.0);
  ASSERT_EQ(ids(*first), (std::vector<KeyframeId>{0}));
  a.onRequest({"robot_b", "robot_a", first->sequence, {0}}, 0.0);
  a.onReceipt({"robot_b", "robot_a", {0}});
  a.setLink("robot_b", link(50000.0));
  // Place A is known to b now: B is worth more than A's second scan.
  EXPECT_EQ(ids(*a.makeOffer("robot_b", 1.0)), (std::vector<KeyframeId>{2}));
}

TEST_F(Provider, RedundantScansOfOnePlaceAreNotBothOffered) {
  //   0: A   1: A again   2: C (half of A's size)
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceA());
  keyframe(2, kPlaceC());
  a.setLink("robot_b", link(100000.0));  // two scans a period
  EXPECT_EQ(ids(*a.makeOffer("robot_b", 0.0)), (std::vector<KeyframeId>{0, 2}));
}

TEST_F(Provider, WithAnUnknownTransformHighCorrespondenceScansRankFirst) {
  //   0: A (10 blocks, c_k 0)   1: C (5 blocks, c_k 3)   2: B (10 blocks, c_k 2)
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceC());
  keyframe(2, kPlaceB());
  a.setCorrespondences("robot_b", 1, 3);
  a.setCorrespondences("robot_b", 2, 2);
  a.setCorrespondences("robot_b", 2, 1);  // the largest c_k seen is kept
  a.setLink("robot_b", link());
  const auto offer = a.makeOffer("robot_b", 0.0);
  EXPECT_EQ(ids(*offer), (std::vector<KeyframeId>{1, 2, 0}));
  EXPECT_EQ(offer->scans[0].correspondences, 3);
  EXPECT_GT(offer->scans[0].utility, offer->scans[1].utility);
  // Once the transform is known, map information weighs fully (k = 1): B's 10 blocks and
  // c_k 2 beat C's 5 blocks and c_k 3.
  a.setTeamTransform("robot_b", Pose3::Identity());
  a.setLink("robot_b", link());
  EXPECT_EQ(ids(*a.makeOffer("robot_b", 0.0)).front(), 2u);
}

TEST_F(Provider, PoseUncertaintyWeighsTheLoopClosureUtilityOnceTheTransformIsKnown) {
  CcirBroker b("robot_a", {"robot_b"}, params(1.0));  // lambda 1: F alone
  for (KeyframeId id = 0; id < 3; ++id)
    b.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, kPlaceA());
  for (KeyframeId id = 0; id < 3; ++id) b.setCorrespondences("robot_b", id, 10);
  b.setUncertainty(0, 0.01);
  b.setUncertainty(1, 0.50);
  b.setUncertainty(2, 0.20);
  b.setTeamTransform("robot_b", Pose3::Identity());
  b.setLink("robot_b", link());
  EXPECT_EQ(ids(*b.makeOffer("robot_b", 0.0)), (std::vector<KeyframeId>{1, 2, 0}));
}

TEST_F(Provider, LambdaZeroGivesTheGreedyInformationOrder) {
  BrokerParams p = params(0.0);
  p.min_novelty = 0.0;  // the plain greedy order, nothing held back
  CcirBroker b("robot_a", {"robot_b"}, p);
  std::vector<std::vector<VoxelGain>> gains = {blocks(0, 10), blocks(5, 10), blocks(12, 4),
                                               blocks(30, 6, 0.5F), blocks(2, 3, 2.0F)};
  for (KeyframeId id = 0; id < gains.size(); ++id) {
    b.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, gains[id]);
    b.setCorrespondences("robot_b", id, int(10 * id));  // ignored at lambda 0
  }
  b.setLink("robot_b", link(5 * 50000.0));
  const auto offer = b.makeOffer("robot_b", 0.0);
  const auto greedy = information::ScanRanker(gains).rankNaive(5);
  std::vector<KeyframeId> expected;
  for (const auto& r : greedy) {
    if (r.gain > 0) expected.push_back(r.index);
  }
  EXPECT_EQ(ids(*offer), expected);
}

TEST_F(Provider, NothingWorthSendingIsNotOffered) {
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceA());
  a.setLink("robot_b", link());
  const auto offer = a.makeOffer("robot_b", 0.0);
  ASSERT_EQ(ids(*offer), (std::vector<KeyframeId>{0}));  // the twin adds nothing
  a.onRequest({"robot_b", "robot_a", offer->sequence, {0}}, 0.0);
  a.setLink("robot_b", link());
  EXPECT_FALSE(a.makeOffer("robot_b", 1.0)) << "b holds all there is to see";
}

TEST_F(Provider, ARequestThatCrossedNewerOffersIsStillServed) {
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceB());
  a.setLink("robot_b", link(50000.0));
  const auto first = a.makeOffer("robot_b", 0.0);
  ASSERT_EQ(ids(*first), (std::vector<KeyframeId>{0}));
  for (int i = 0; i < 6; ++i) {  // b's answer is late: a offers on meanwhile
    a.setLink("robot_b", link(50000.0));
    ASSERT_TRUE(a.makeOffer("robot_b", 1.0 + i));
  }
  EXPECT_EQ(a.onRequest({"robot_b", "robot_a", first->sequence, {0}}, 7.0).send,
            (std::vector<KeyframeId>{0}));
  EXPECT_EQ(a.onRequest({"robot_b", "robot_a", 99, {1}}, 7.0).refused.count("unknown_offer"), 1u)
      << "an offer never made";
}

TEST(ProviderNovelty, AScanMostlyKnownToTheTeammateStaysHome) {
  //   0: blocks 0..9 (sent)   1: blocks 2..11 (8 of 10 known)   2: blocks 40..44 (new)
  for (const double min_novelty : {0.25, 0.1}) {
    BrokerParams p;
    p.min_novelty = min_novelty;
    CcirBroker a("robot_a", {"robot_b"}, p);
    a.addKeyframe(0, 0, Pose3::Identity(), kScanBytes, blocks(0, 10));
    a.setLink("robot_b", link(50000.0));
    const auto first = a.makeOffer("robot_b", 0.0);
    a.onRequest({"robot_b", "robot_a", first->sequence, {0}}, 0.0);
    a.addKeyframe(1, 1, Pose3::Identity(), kScanBytes, blocks(2, 10));
    a.addKeyframe(2, 2, Pose3::Identity(), kScanBytes, blocks(40, 5));
    a.setLink("robot_b", link(100000.0));
    const auto offer = a.makeOffer("robot_b", 1.0);
    ASSERT_TRUE(offer);
    const std::vector<KeyframeId> expected =
        min_novelty > 0.2 ? std::vector<KeyframeId>{2} : std::vector<KeyframeId>{2, 1};
    EXPECT_EQ(ids(*offer), expected) << "min_novelty " << min_novelty;
  }
}

TEST_F(Provider, MalformedRequestsAndReceiptsAreRefusedAndCounted) {
  keyframe(0, kPlaceA());
  keyframe(1, kPlaceB());
  a.setLink("robot_b", link(50000.0));
  const auto offer = a.makeOffer("robot_b", 0.0);  // {0}
  ASSERT_EQ(ids(*offer), (std::vector<KeyframeId>{0}));
  EXPECT_EQ(
      a.onRequest({"robot_x", "robot_a", offer->sequence, {0}}, 0.0).refused.count("unknown_robot"),
      1u);
  EXPECT_EQ(a.onRequest({"robot_b", "robot_c", offer->sequence, {0}}, 0.0)
                .refused.count("not_for_this_robot"),
            1u);
  EXPECT_EQ(a.onRequest({"robot_b", "robot_a", 77, {0}}, 0.0).refused.count("unknown_offer"), 1u);
  EXPECT_EQ(a.onRequest({"robot_b", "robot_a", offer->sequence, {0, 0, 0}}, 0.0)
                .refused.count("oversized"),
            1u);
  const auto not_offered = a.onRequest({"robot_b", "robot_a", offer->sequence, {1}}, 0.0);
  EXPECT_TRUE(not_offered.send.empty());
  EXPECT_EQ(not_offered.refused.at("not_offered"), 1);
  EXPECT_FALSE(a.onReceipt({"robot_x", "robot_a", {0}}));
  EXPECT_TRUE(a.onReceipt({"robot_b", "robot_a", {5}}));
  const auto& refused = a.counters().at("robot_b").refused;
  EXPECT_EQ(refused.at("not_for_this_robot"), 1u);
  EXPECT_EQ(refused.at("unknown_offer"), 1u);
  EXPECT_EQ(refused.at("oversized"), 1u);
  EXPECT_EQ(refused.at("not_offered"), 1u);
  EXPECT_EQ(refused.at("receipt_for_unsent"), 1u);
  EXPECT_EQ(a.counters().at("").refused.at("unknown_robot"), 2u);  // strangers
  EXPECT_EQ(a.counters().at("robot_b").scans_sent, 0u);
}

TEST_F(Provider, ARequestForAnEvictedScanIsRefused) {
  CcirBroker b("robot_a", {"robot_b"}, [] {
    BrokerParams p;
    p.max_kept_scans = 2;
    return p;
  }());
  b.addKeyframe(0, Stamp(0), Pose3::Identity(), kScanBytes, kPlaceA());
  b.addKeyframe(1, Stamp(1), Pose3::Identity(), kScanBytes, kPlaceB());
  b.setLink("robot_b", link(50000.0));
  const auto offer = b.makeOffer("robot_b", 0.0);
  ASSERT_EQ(ids(*offer), (std::vector<KeyframeId>{0}));
  EXPECT_EQ(b.addKeyframe(2, Stamp(2), Pose3::Identity(), kScanBytes, kPlaceC()),
            (std::vector<KeyframeId>{0}));
  EXPECT_EQ(b.report().kept_scans, 2u);
  const auto outcome = b.onRequest({"robot_b", "robot_a", offer->sequence, {0}}, 0.0);
  EXPECT_TRUE(outcome.send.empty());
  EXPECT_EQ(outcome.refused.at("evicted"), 1);
}

TEST_F(Provider, AScanNeverAcknowledgedIsOfferedAgainAfterTheTimeout) {
  keyframe(0, kPlaceA());
  a.setLink("robot_b", link());
  const auto offer = a.makeOffer("robot_b", 0.0);
  a.onRequest({"robot_b", "robot_a", offer->sequence, {0}}, 0.0);
  a.setLink("robot_b", link());
  EXPECT_FALSE(a.makeOffer("robot_b", 30.0));
  const auto again = a.makeOffer("robot_b", 61.0);  // receipt_timeout_s 60: lost on the way
  ASSERT_TRUE(again);
  EXPECT_EQ(ids(*again), (std::vector<KeyframeId>{0}));
  EXPECT_EQ(a.counters().at("robot_b").refused.at("unacknowledged"), 1u);
}

TEST(FixedRateAndAll, SendDirectlyToEveryPeer) {
  BrokerParams p;
  p.mode = RoutingMode::kFixedRate;
  p.fixed_rate_every_n = 3;
  CcirBroker fixed("robot_a", {"robot_b", "robot_c"}, p);
  std::vector<KeyframeId> sent;
  for (KeyframeId id = 0; id < 7; ++id) {
    fixed.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, kPlaceA());
    if (fixed.sendsToAll(id)) sent.push_back(id);
  }
  EXPECT_EQ(sent, (std::vector<KeyframeId>{0, 3, 6}));
  EXPECT_EQ(fixed.counters().at("robot_c").scans_sent, 3u);
  fixed.setLink("robot_b", link());
  EXPECT_FALSE(fixed.makeOffer("robot_b", 0.0)) << "no offers outside ccir";

  p.mode = RoutingMode::kAll;
  CcirBroker all("robot_a", {"robot_b"}, p);
  for (KeyframeId id = 0; id < 4; ++id) {
    all.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, kPlaceA());
    EXPECT_TRUE(all.sendsToAll(id));
  }
  p.mode = RoutingMode::kCcir;
  CcirBroker ccir("robot_a", {"robot_b"}, p);
  ccir.addKeyframe(0, Stamp(0), Pose3::Identity(), kScanBytes, kPlaceA());
  EXPECT_FALSE(ccir.sendsToAll(0));
}

/// Robot b requesting from a and c.
struct Requester : ::testing::Test {
  CcirBroker b{"robot_b", {"robot_a", "robot_c"}, params()};
  Offer offer(const std::string& provider, std::vector<std::pair<KeyframeId, int>> scans,
              std::uint32_t sequence = 1) {
    Offer o;
    o.provider = provider;
    o.requester = "robot_b";
    o.sequence = sequence;
    for (const auto& [id, c] : scans) {
      OfferEntry e;
      e.id = id;
      e.pose = Pose3(Eigen::Translation3d(double(id), 0, 0));
      e.correspondences = c;
      e.size_bytes = kScanBytes;
      o.scans.push_back(e);
    }
    return o;
  }
  static double noInformation(const Pose3&) { return 0.0; }
};

TEST_F(Requester, RequestsAreASubsetOfTheOffersWithinWhatTheLinksCarry) {
  b.setLink("robot_a", link(150000.0));
  b.setLink("robot_c", link(150000.0));
  ASSERT_TRUE(b.onOffer(offer("robot_a", {{0, 1}, {1, 9}, {2, 4}}, 5)));
  ASSERT_TRUE(b.onOffer(offer("robot_c", {{7, 3}, {8, 12}})));
  const auto requests = b.chooseRequests(noInformation, 0.0);
  // 75 KB per link and period (two links share 150 KB/s): one scan from each, the best c_k.
  ASSERT_EQ(requests.size(), 2u);
  EXPECT_EQ(requests[0].provider, "robot_a");
  EXPECT_EQ(requests[0].requester, "robot_b");
  EXPECT_EQ(requests[0].offer_sequence, 5u);
  EXPECT_EQ(requests[0].ids, (std::vector<KeyframeId>{1}));
  EXPECT_EQ(requests[1].ids, (std::vector<KeyframeId>{8}));
  EXPECT_TRUE(b.chooseRequests(noInformation, 0.0).empty()) << "each offer is answered once";
}

TEST_F(Requester, AKnownTransformLetsTheOwnMapsInformationChoose) {
  CcirBroker r("robot_b", {"robot_a"}, params(0.5));
  r.setLink("robot_a", link(100000.0));  // two scans a period
  // robot_a's map frame is 100 m along x in robot_b's: offered scan k (at x = k in robot_a's
  // frame) is seen from x = 100 + k in the own map.
  r.setTeamTransform("robot_a", Pose3(Eigen::Translation3d(100.0, 0.0, 0.0)));
  ASSERT_TRUE(r.onOffer(offer("robot_a", {{0, 5}, {1, 5}, {2, 5}})));
  // Equal c_k: the scan whose simulated view the own map knows least wins.
  const auto requests = r.chooseRequests(
      [](const Pose3& sensor_pose) {
        const double x = sensor_pose.translation().x();
        return x == 102.0 ? 300.0 : x == 100.0 ? 100.0 : 10.0;
      },
      0.0);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].ids, (std::vector<KeyframeId>{2, 0}));
}

TEST_F(Requester, MalformedOffersAreRefusedAndDuplicatesNotAcknowledgedTwice) {
  std::string reason;
  EXPECT_FALSE(b.onOffer(offer("robot_x", {{0, 1}}), &reason));
  EXPECT_EQ(reason, "unknown_robot");
  auto wrong = offer("robot_a", {{0, 1}});
  wrong.requester = "robot_c";
  EXPECT_FALSE(b.onOffer(wrong, &reason));
  EXPECT_EQ(reason, "not_for_this_robot");
  std::vector<std::pair<KeyframeId, int>> many;
  for (KeyframeId id = 0; id < 101; ++id) many.emplace_back(id, 1);
  EXPECT_FALSE(b.onOffer(offer("robot_a", many), &reason));
  EXPECT_EQ(reason, "oversized");
  EXPECT_EQ(b.counters().at("robot_a").refused.at("oversized"), 1u);

  EXPECT_TRUE(b.onScanReceived("robot_a", 4, kScanBytes));
  EXPECT_FALSE(b.onScanReceived("robot_a", 4, kScanBytes));
  EXPECT_FALSE(b.onScanReceived("robot_x", 4, kScanBytes));
  const auto receipts = b.takeReceipts();
  ASSERT_EQ(receipts.size(), 1u);
  EXPECT_EQ(receipts[0].receiver, "robot_b");
  EXPECT_EQ(receipts[0].provider, "robot_a");
  EXPECT_EQ(receipts[0].ids, (std::vector<KeyframeId>{4}));
  EXPECT_TRUE(b.takeReceipts().empty());
  // A scan already received is not requested again.
  b.setLink("robot_a", link());
  ASSERT_TRUE(b.onOffer(offer("robot_a", {{4, 9}, {5, 1}})));
  const auto requests = b.chooseRequests(noInformation, 0.0);
  ASSERT_EQ(requests.size(), 1u);
  EXPECT_EQ(requests[0].ids, (std::vector<KeyframeId>{5}));
}

TEST_F(Requester, AScanOnItsWayIsNotRequestedAgainUntilTheReceiptTimeout) {
  b.setLink("robot_a", link());
  ASSERT_TRUE(b.onOffer(offer("robot_a", {{3, 5}}, 1)));
  ASSERT_EQ(b.chooseRequests(noInformation, 0.0).size(), 1u);
  ASSERT_TRUE(b.onOffer(offer("robot_a", {{3, 5}}, 2)));  // offered again before it arrived
  EXPECT_TRUE(b.chooseRequests(noInformation, 1.0).empty());
  ASSERT_TRUE(b.onOffer(offer("robot_a", {{3, 5}}, 3)));
  EXPECT_EQ(b.chooseRequests(noInformation, 61.0).size(), 1u) << "lost on the way: asked again";
}

TEST(CcirScenario, TwoRobotsExchangeEachPlaceOnceUnderTheBudget) {
  // a walks A, A, B, B, C; b offers nothing. Each period a offers, b requests, a sends, b
  // acknowledges: every place reaches b once, the twins never.
  CcirBroker a("robot_a", {"robot_b"}, params());
  CcirBroker b("robot_b", {"robot_a"}, params());
  const std::vector<std::vector<VoxelGain>> walk = {kPlaceA(), kPlaceA(), kPlaceB(), kPlaceB(),
                                                    kPlaceC()};
  std::vector<KeyframeId> delivered;
  for (KeyframeId id = 0; id < 8; ++id) {
    if (id < walk.size()) a.addKeyframe(id, Stamp(id), Pose3::Identity(), kScanBytes, walk[id]);
    a.setLink("robot_b", link(60000.0));  // one scan a period
    b.setLink("robot_a", link(60000.0));
    if (const auto offer = a.makeOffer("robot_b", double(id))) ASSERT_TRUE(b.onOffer(*offer));
    for (const auto& request : b.chooseRequests(Requester::noInformation, double(id))) {
      for (const KeyframeId sent : a.onRequest(request, double(id)).send) {
        EXPECT_TRUE(b.onScanReceived("robot_a", sent, kScanBytes));
        delivered.push_back(sent);
      }
    }
    for (const auto& receipt : b.takeReceipts()) EXPECT_TRUE(a.onReceipt(receipt));
  }
  EXPECT_EQ(delivered, (std::vector<KeyframeId>{0, 2, 4}));
  EXPECT_EQ(a.counters().at("robot_b").receipts_received, 3u);
  EXPECT_EQ(b.counters().at("robot_a").scan_bytes_received, 3 * kScanBytes);
  const BrokerReport sent = a.report();
  EXPECT_EQ(sent.robot, "robot_a");
  EXPECT_EQ(sent.mode, RoutingMode::kCcir);
  EXPECT_EQ(sent.keyframes, walk.size());
  EXPECT_EQ(sent.kept_scans, walk.size());
  EXPECT_EQ(sent.scans_sent, 3u);
  EXPECT_EQ(sent.scans_received, 0u);
  EXPECT_EQ(sent.peers.at("robot_b").scans_sent, 3u);
  EXPECT_EQ(b.report().scans_received, 3u);
}

TEST(CcirScenario, APeriodOffersThenRequestsThenAcknowledges) {
  CcirBroker a("robot_a", {"robot_b"}, params());
  CcirBroker b("robot_b", {"robot_a"}, params());
  a.addKeyframe(0, Stamp(0), Pose3::Identity(), kScanBytes, kPlaceA());
  a.setLink("robot_b", link());
  b.setLink("robot_a", link());
  const auto first = a.runPeriod(Requester::noInformation, 0.0);
  ASSERT_EQ(first.offers.size(), 1u);
  EXPECT_EQ(first.offers[0].requester, "robot_b");
  EXPECT_TRUE(first.requests.empty());
  EXPECT_TRUE(first.receipts.empty());
  ASSERT_TRUE(b.onOffer(first.offers[0]));
  const auto asked = b.runPeriod(Requester::noInformation, 0.0);
  EXPECT_TRUE(asked.offers.empty()) << "b has no keyframe";
  ASSERT_EQ(asked.requests.size(), 1u);
  EXPECT_EQ(a.onRequest(asked.requests[0], 0.0).send, (std::vector<KeyframeId>{0}));
  ASSERT_TRUE(b.onScanReceived("robot_a", 0, kScanBytes));
  const auto acknowledged = b.runPeriod(Requester::noInformation, 1.0);
  EXPECT_TRUE(acknowledged.requests.empty());
  ASSERT_EQ(acknowledged.receipts.size(), 1u);
  EXPECT_EQ(acknowledged.receipts[0].ids, (std::vector<KeyframeId>{0}));
}

/// A wall of points 5 m ahead of the sensor.
pcl::PointCloud<pcl::PointXYZ> wallAhead() {
  pcl::PointCloud<pcl::PointXYZ> points;
  for (int i = -10; i <= 10; ++i) {
    for (int k = -3; k <= 3; ++k) points.push_back({5.0F, 0.2F * float(i), 0.2F * float(k)});
  }
  return points;
}

TEST(BrokerStage, KeepsTheWireFormWhileCcirKeepsItsKeyframe) {
  BrokerParams p;
  p.mode = RoutingMode::kFixedRate;
  p.fixed_rate_every_n = 2;
  p.max_kept_scans = 2;
  BrokerStage<std::string> stage("robot_a", {"robot_b"}, p, information::MapperParams{});
  std::vector<std::string> to_all;
  for (KeyframeId id = 0; id < 4; ++id) {
    const auto out = stage.addKeyframe(id, Stamp(id), Pose3::Identity(), wallAhead(),
                                       "scan " + std::to_string(id), kScanBytes);
    for (const auto& [peer, scan] : out.scans) {
      EXPECT_EQ(peer, "") << "to every teammate";
      to_all.push_back(scan);
    }
    EXPECT_TRUE(out.offers.empty() && out.refused.empty());
  }
  EXPECT_EQ(to_all, (std::vector<std::string>{"scan 0", "scan 2"}));
  EXPECT_EQ(stage.keptScans(), 2u) << "the oldest go with their keyframes";
  EXPECT_EQ(stage.ccir().report().kept_scans, 2u);
}

TEST(BrokerStage, EachStepSaysWhatToSendAndWhatItRefused) {
  using Stage = BrokerStage<std::string>;
  Stage a("robot_a", {"robot_b"}, params(), information::MapperParams{});
  Stage b("robot_b", {"robot_a"}, params(), information::MapperParams{});
  const auto kept = a.addKeyframe(0, Stamp(0), Pose3::Identity(), wallAhead(), "scan 0", 1000);
  EXPECT_TRUE(kept.scans.empty()) << "ccir sends nothing unasked";
  a.addKeyframe(1, Stamp(1), Pose3(Eigen::Translation3d(0.0, 20.0, 0.0)), wallAhead(), "scan 1",
                1000);
  a.ccir().setLink("robot_b", link());
  b.ccir().setLink("robot_a", link());

  // No map set (setMap): CSQMI counts nothing.
  const Stage::Output offered = a.runPeriod(0.0);
  ASSERT_EQ(offered.offers.size(), 1u);
  ASSERT_EQ(offered.offers[0].scans.size(), 2u) << "both show new places";
  EXPECT_TRUE(b.onOffer(offered.offers[0]).refused.empty());
  const auto malformed = b.onOffer(offered.offers[0], std::string("pose not finite"));
  ASSERT_EQ(malformed.refused.size(), 1u);
  EXPECT_EQ(malformed.refused[0].text, "refusing an offer from 'robot_a': pose not finite");
  EXPECT_EQ(b.ccir().counters().at("robot_a").refused.at("malformed_offer"), 1u);

  const Stage::Output asked = b.runPeriod(0.0);
  ASSERT_EQ(asked.requests.size(), 1u);
  EXPECT_EQ(asked.requests[0].provider, "robot_a");
  const Request first{"robot_b", "robot_a", offered.offers[0].sequence, {0}};
  const Stage::Output sent = a.onRequest(first, 0.0);
  ASSERT_EQ(sent.scans.size(), 1u);
  EXPECT_EQ(sent.scans[0], std::make_pair(std::string("robot_b"), std::string("scan 0")));
  EXPECT_TRUE(sent.refused.empty());
  const Stage::Output again = a.onRequest(first, 0.0);
  EXPECT_TRUE(again.scans.empty());
  ASSERT_EQ(again.refused.size(), 1u);
  EXPECT_EQ(again.refused[0].kind, "request already_sent");
  EXPECT_EQ(again.refused[0].text, "refusing 1 scan(s) robot_b asked for: already_sent");

  EXPECT_TRUE(b.onScan("robot_a", 0, 1000).refused.empty());
  const auto twice = b.onScan("robot_a", 0, 1000);
  ASSERT_EQ(twice.refused.size(), 1u);
  EXPECT_EQ(twice.refused[0].text,
            "dropping scan 0 of 'robot_a': received before, or not a "
            "teammate's");
  EXPECT_EQ(b.onScan("robot_a", 1, 1000, std::string("truncated")).refused[0].text,
            "dropping scan 1 of 'robot_a': truncated");
  EXPECT_EQ(b.ccir().counters().at("robot_a").refused.at("undecodable_scan"), 1u);

  const Stage::Output acknowledged = b.runPeriod(1.0);
  ASSERT_EQ(acknowledged.receipts.size(), 1u);
  EXPECT_TRUE(a.onReceipt(acknowledged.receipts[0]).refused.empty());
  EXPECT_EQ(a.onReceipt({"robot_x", "robot_a", {0}}).refused[0].text,
            "refusing a receipt from 'robot_x' for 'robot_a'");
}

TEST(BrokerStage, CountsEachControlMessageAtTheSizeTheWireGivesIt) {
  using Stage = BrokerStage<std::string>;
  std::vector<std::string> sized;
  const auto bytes = [&](const ControlMessage& m) -> std::size_t {
    sized.push_back(std::visit(
        [](const auto& c) -> std::string {
          using T = std::decay_t<decltype(c)>;
          if constexpr (std::is_same_v<T, Offer>) return "offer";
          if constexpr (std::is_same_v<T, Request>) return "request";
          return "receipt";
        },
        m));
    return 100;
  };
  Stage a("robot_a", {"robot_b"}, params(), information::MapperParams{}, bytes);
  Stage b("robot_b", {"robot_a"}, params(), information::MapperParams{}, bytes);
  a.addKeyframe(0, Stamp(0), Pose3::Identity(), wallAhead(), "scan 0", 1000);
  a.ccir().setLink("robot_b", link());
  b.ccir().setLink("robot_a", link());
  const auto offered = a.runPeriod(0.0);
  ASSERT_EQ(offered.offers.size(), 1u);
  EXPECT_EQ(a.ccir().counters().at("robot_b").control_bytes_sent, 100u);
  b.onOffer(offered.offers[0]);
  ASSERT_EQ(b.runPeriod(0.0).requests.size(), 1u);
  EXPECT_EQ(b.ccir().counters().at("robot_a").control_bytes_sent, 100u);
  EXPECT_EQ(sized, (std::vector<std::string>{"offer", "request"}));
  EXPECT_FALSE(a.hasMap());
}

}  // namespace
}  // namespace ccir_mapping::core::routing
