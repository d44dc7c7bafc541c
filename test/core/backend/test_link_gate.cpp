// LinkGate: which inter-robot closures of a link may enter the team graph.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "ccir_mapping/core/backend/link_gate.h"
#include "ccir_mapping/core/testing/synthetic_candidates.h"

namespace ccir_mapping::core::backend {
namespace {

std::vector<LoopKey> keysOf(const testing::SyntheticCandidates& s) {
  std::vector<LoopKey> keys;
  for (std::size_t k = 0; k < s.candidates.size(); ++k) {
    keys.push_back({{"robot_a", KeyframeId(s.index_a[k])}, {"robot_b", KeyframeId(s.index_b[k])}});
  }
  return keys;
}

alignment::AlignmentParams em() {
  alignment::AlignmentParams p;
  p.min_inliers = 10;
  p.min_inlier_margin = 3;
  return p;
}

TEST(LinkGate, AdmitsTheInliersOfTheLinksTransformAndWhatTheSwitchesKept) {
  testing::SyntheticSpec spec;
  spec.inliers = 20;
  spec.outliers = 30;
  const auto s = testing::makeSyntheticCandidates(spec);
  const auto keys = keysOf(s);
  const Link link{"robot_a", "robot_b"};
  LinkGate gate(em());
  const auto found = gate.judge(link, s.candidates, false, 10.0);
  ASSERT_TRUE(found.found);
  for (const LoopKey& key : keys) EXPECT_FALSE(gate.admits(link, key)) << "judged, not admitted";
  gate.admit(link, keys, found);
  int admitted_true = 0;
  int admitted_false = 0;
  for (std::size_t k = 0; k < keys.size(); ++k) {
    (s.inlier[k] ? admitted_true : admitted_false) += gate.admits(link, keys[k]);
  }
  EXPECT_GE(admitted_true, 18);
  EXPECT_EQ(admitted_false, 0);
  EXPECT_FALSE(gate.admits({"robot_a", "robot_c"}, keys[0])) << "per link";

  // A new pass forgets what the EM admitted; what the switches kept stays until forgotten.
  gate.keep({{link, {keys[0]}}});
  gate.clearAdmitted();
  EXPECT_TRUE(gate.admits(link, keys[0]));
  EXPECT_FALSE(gate.admits(link, keys[1]));
  EXPECT_EQ(gate.keptCount(link), 1U);
  gate.forgetKept(link);
  EXPECT_FALSE(gate.admits(link, keys[0]));
  EXPECT_EQ(gate.keptCount(link), 0U);
}

TEST(LinkGate, ReChecksTheLastTransformUntilTheClosuresGrewByTheRerunShare) {
  testing::SyntheticSpec spec;
  spec.inliers = 40;
  spec.outliers = 60;
  const auto s = testing::makeSyntheticCandidates(spec);
  const Link link{"robot_a", "robot_b"};
  LinkGate gate(em());
  // 90 of the 100 closures, one true one held back for each step below.
  std::vector<alignment::AlignmentCandidate> list;
  std::vector<alignment::AlignmentCandidate> held;
  for (std::size_t k = 0; k < s.candidates.size(); ++k) {
    (list.size() < 90 && !(s.inlier[k] && held.size() < 10) ? list : held)
        .push_back(s.candidates[k]);
  }
  ASSERT_EQ(list.size(), 90U);
  const auto first = gate.judge(link, list, true, 10.0);
  ASSERT_TRUE(first.found);
  list.push_back(held[0]);  // 1 % more: the last transform, re-checked
  const auto rechecked = gate.judge(link, list, true, 10.0);
  EXPECT_TRUE(rechecked.found);
  EXPECT_EQ(rechecked.inliers.size(), list.size());
  EXPECT_TRUE(rechecked.transform.isApprox(first.transform, 0.0));
  EXPECT_FALSE(gate.judge(link, list, false, 10.0).transform.isApprox(first.transform, 1e-12))
      << "without recheck, the EM";
  list.insert(list.end(), held.begin() + 1, held.end());  // 10 % more than its last full run
  const auto rerun = gate.judge(link, list, true, 10.0);
  EXPECT_FALSE(rerun.transform.isApprox(first.transform, 1e-12));
}

}  // namespace
}  // namespace ccir_mapping::core::backend
