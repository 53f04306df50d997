// The host's PTP state from linuxptp's pmc (sync/ptp_host.h): answers as pmc 3.1.1 (Debian 12) printed
// them (captured once, kept as files) for a ptp4l grandmaster and a follower in two network namespaces joined by a veth pair
// (software timestamping, free_running 1), and the judgement a session's start makes of them.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>
#include <string>

#include "sync/ptp_host.h"

namespace {

using pvcap::sync::parse_pmc_answer;
using pvcap::sync::ptp_host_out_of_time;

// The captures themselves are the pmc fuzzer's seeds (tests/fuzz/seeds_pmc_answer/), read in place.
std::string capture(const char* name) {
  std::ifstream in(std::string(PVCAP_SOURCE_DIR) + "/tests/fuzz/seeds_pmc_answer/" + name);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
const std::string kGrandmaster = capture("grandmaster");
const std::string kFollower = capture("follower");

TEST(PtpHost, AGrandmastersAnswerIsItsOwnTime) {
  const auto s = parse_pmc_answer(kGrandmaster);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s.value().port_state, "MASTER");
  EXPECT_EQ(s.value().clock_identity, "860239.fffe.868401");
  EXPECT_EQ(s.value().grandmaster, "860239.fffe.868401");
  EXPECT_TRUE(s.value().is_grandmaster());
  EXPECT_FALSE(s.value().gm_present);  // ptp4l says so of itself
  EXPECT_EQ(s.value().steps_removed, 0);
  EXPECT_EQ(ptp_host_out_of_time(s.value(), 1000), std::nullopt);
}

TEST(PtpHost, AFollowersAnswerGivesItsOffsetAndGrandmaster) {
  const auto s = parse_pmc_answer(kFollower);
  ASSERT_TRUE(s) << s.error().message;
  EXPECT_EQ(s.value().port_state, "UNCALIBRATED");  // free_running 1: it measures, never locks
  EXPECT_EQ(s.value().clock_identity, "ae0e5a.fffe.382930");
  EXPECT_EQ(s.value().grandmaster, "860239.fffe.868401");
  EXPECT_FALSE(s.value().is_grandmaster());
  EXPECT_TRUE(s.value().gm_present);
  EXPECT_DOUBLE_EQ(s.value().offset_ns, -292.0);
  EXPECT_DOUBLE_EQ(s.value().path_delay_ns, 2245.0);
  EXPECT_EQ(s.value().steps_removed, 1);
  EXPECT_EQ(ptp_host_out_of_time(s.value(), 1000), std::nullopt);
  const auto over = ptp_host_out_of_time(s.value(), 100);
  ASSERT_TRUE(over);
  EXPECT_NE(over->find("-292 ns from its master, over the limit of 100 ns"), std::string::npos) << *over;
}

TEST(PtpHost, AHostHearingNoGrandmasterOrNotFollowingIsOutOfTimeWithWhy) {
  auto s = parse_pmc_answer(kFollower).value();
  s.gm_present = false;
  s.port_state = "LISTENING";
  const auto alone = ptp_host_out_of_time(s, 1000);
  ASSERT_TRUE(alone);
  EXPECT_NE(alone->find("hears no grandmaster (its port is LISTENING)"), std::string::npos) << *alone;
  s.gm_present = true;
  s.port_state = "FAULTY";
  const auto faulty = ptp_host_out_of_time(s, 1000);
  ASSERT_TRUE(faulty);
  EXPECT_NE(faulty->find("port is FAULTY, not following grandmaster 860239.fffe.868401"), std::string::npos) << *faulty;
  s.port_state = "SLAVE";
  EXPECT_EQ(ptp_host_out_of_time(s, 1000), std::nullopt);
  // Its master chosen, nothing measured yet (pmc says 0.0 for both until the first exchange).
  s.offset_ns = 0;
  s.path_delay_ns = 0;
  const auto unmeasured = ptp_host_out_of_time(s, 1000);
  ASSERT_TRUE(unmeasured);
  EXPECT_NE(unmeasured->find("has not measured its offset yet"), std::string::npos) << *unmeasured;
}

TEST(PtpHost, AMissingAnswerOrFieldIsNamed) {
  // No ptp4l at the socket: pmc prints what it sent and nothing else.
  const auto none = parse_pmc_answer("sending: GET CURRENT_DATA_SET\nsending: GET PORT_DATA_SET\n");
  ASSERT_FALSE(none);
  EXPECT_NE(none.error().message.find("no PORT_DATA_SET"), std::string::npos) << none.error().message;
  std::string no_offset = kFollower;
  no_offset.erase(no_offset.find("\t\toffsetFromMaster"), no_offset.find("\t\tmeanPathDelay") - no_offset.find("\t\toffsetFromMaster"));
  const auto missing = parse_pmc_answer(no_offset);
  ASSERT_FALSE(missing);
  EXPECT_EQ(missing.error().message, "pmc's CURRENT_DATA_SET has no offsetFromMaster");
  std::string garbled = kFollower;
  garbled.replace(garbled.find("-292.0"), 6, "-29x.0");
  const auto bad = parse_pmc_answer(garbled);
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().message, "pmc's CURRENT_DATA_SET offsetFromMaster is not a number: '-29x.0'");
}

TEST(PtpHost, ADescriptionSaysWhoItFollowsAndHowFar) {
  EXPECT_EQ(pvcap::sync::describe(parse_pmc_answer(kFollower).value()),
            "UNCALIBRATED of 860239.fffe.868401, offset -292 ns, path delay 2245 ns");
  EXPECT_EQ(pvcap::sync::describe(parse_pmc_answer(kGrandmaster).value()), "MASTER (the grandmaster, 860239.fffe.868401)");
}

}  // namespace
