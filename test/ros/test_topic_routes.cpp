// The Bridge's topic names (ros/topic_routes.h): outbox topics to every teammate or one, the
// inbox they arrive on, and what a teammate's claimed topic name may be republished as.
#include <gtest/gtest.h>

#include "ccir_mapping/ros/topic_routes.h"
#include "ccir_mapping/ros/topics.h"

namespace ccir_mapping::topics {
namespace {

TEST(TopicRoutes, AForwardedTopicGoesToEveryTeammateOrToOne) {
  const auto routes = outboxRoutes(kOutboxScans, {"robot_b", "robot_c"});
  ASSERT_EQ(routes.size(), 3U);
  EXPECT_EQ(routes[0].outbox, "outbox/scans");
  EXPECT_EQ(routes[0].peer, "");
  EXPECT_EQ(routes[1].outbox, outboxTo("robot_b", "scans"));
  EXPECT_EQ(routes[1].outbox, "outbox/to/robot_b/scans");
  EXPECT_EQ(routes[1].peer, "robot_b");
  EXPECT_EQ(routes[2].peer, "robot_c");
  EXPECT_EQ(inboxOf(kOutboxScans), kInboxScans);
  EXPECT_EQ(inboxOf(kOutboxLoopClosures), kInboxLoopClosures);
  EXPECT_EQ(inboxOf("outbox/custom/topic"), "inbox/custom/topic");
}

TEST(TopicRoutes, ATeammatesMessageIsRepublishedUnderItsTopicAndUnderItsName) {
  std::string error;
  const auto names = inboxRepublished(kInboxOffers, "robot_b", &error);
  ASSERT_TRUE(names) << error;
  EXPECT_EQ(*names, (std::vector<std::string>{"inbox/offers", "inbox/robot_b/offers"}));
  for (const char* claimed :
       {"/rosout", "outbox/scans", "inbox/", "inbox/../tf", "inbox/a b", "tf"}) {
    error.clear();
    EXPECT_FALSE(inboxRepublished(claimed, "robot_b", &error)) << claimed;
    EXPECT_FALSE(error.empty()) << claimed;
  }
}

}  // namespace
}  // namespace ccir_mapping::topics
