// The report's PTP time section (report/ptp_time.h) from the events a recording stores each second.
#include <gtest/gtest.h>

#include "report/ptp_time.h"

namespace {

using pvcap::EventRecord;
using pvcap::report::ptp_time_section;

constexpr std::int64_t kStart = 1'000'000'000'000;
std::int64_t at(double s) { return kStart + std::int64_t(s * 1e9); }

EventRecord reading(double s, double offset_ns, bool in_time) {
  return {at(s), "ptp_host_state", std::nullopt,
          nlohmann::json{{"port_state", "SLAVE"}, {"grandmaster", "860239.fffe.868401"}, {"offset_ns", offset_ns},
                         {"in_time", in_time}}
              .dump()};
}

TEST(PtpTime, ASessionWithoutPtpHasNoSection) {
  EXPECT_EQ(ptp_time_section({{at(1), "camera_lost", 3, "cam0 lost"}}, kStart), std::nullopt);
}

TEST(PtpTime, ReadingsAreSummedAndSecondsOutOfTimeInARowAreOneStretch) {
  std::vector<EventRecord> events = {reading(0.1, 120, true), reading(1.1, -900, true), reading(2.1, 40, true)};
  for (double s : {3.1, 4.1, 5.2}) events.push_back({at(s), "ptp_host_out_of_time", std::nullopt, "no answer from ptp4l"});
  events.push_back(reading(6.1, 3000, false));
  events.push_back({at(6.1), "ptp_host_out_of_time", std::nullopt, "3000 ns from its master"});
  events.push_back(reading(7.1, 10, true));
  events.push_back({at(9.1), "ptp_host_out_of_time", std::nullopt, "hears no grandmaster"});
  const auto p = ptp_time_section(events, kStart);
  ASSERT_TRUE(p);
  const auto& j = *p;
  EXPECT_EQ(j["readings"], 5);
  EXPECT_EQ(j["in_time"], 4);
  EXPECT_EQ(j["seconds_out_of_time"], 5);
  EXPECT_DOUBLE_EQ(j["worst_offset_ns"].get<double>(), 3000);
  EXPECT_EQ(j["grandmasters"], nlohmann::json::array({"860239.fffe.868401"}));
  ASSERT_EQ(j["out_of_time"].size(), 2u) << j.dump();
  EXPECT_DOUBLE_EQ(j["out_of_time"][0]["from_s"].get<double>(), 3.1);
  EXPECT_DOUBLE_EQ(j["out_of_time"][0]["to_s"].get<double>(), 6.1);
  EXPECT_EQ(j["out_of_time"][0]["seconds"], 4);
  EXPECT_EQ(j["out_of_time"][0]["why"], "3000 ns from its master");
  EXPECT_EQ(j["out_of_time"][1]["seconds"], 1);
  EXPECT_EQ(j["out_of_time"][1]["why"], "hears no grandmaster");
}

TEST(PtpTime, AReadingThatIsNotJsonOrHasOddFieldsIsCountedAndSkipped) {
  const auto p = ptp_time_section({{at(1), "ptp_host_state", std::nullopt, "{not json"},
                                   {at(2), "ptp_host_state", std::nullopt, R"({"in_time": "yes", "offset_ns": "far"})"}},
                                  kStart);
  ASSERT_TRUE(p);
  EXPECT_EQ((*p)["readings"], 2);
  EXPECT_EQ((*p)["in_time"], 0);
  EXPECT_DOUBLE_EQ((*p)["worst_offset_ns"].get<double>(), 0);
}

}  // namespace

namespace {
TEST(PtpTime, EachCamerasReadingsAndSecondsOutOfLockAreSummedByName) {
  auto cam = [](double s, std::int64_t device, bool locked, double offset) {
    return EventRecord{at(s), "ptp_camera_state", device,
                       nlohmann::json{{"status", locked ? "Slave" : "Uncalibrated"}, {"locked", locked},
                                      {"offset_ns", offset}}
                           .dump()};
  };
  const std::vector<EventRecord> events = {
      cam(1, 7, true, -30), cam(1, 8, true, 45),  cam(2, 7, true, 12), cam(2, 8, false, 20000),
      {at(2), "ptp_camera_out_of_lock", 8, "cam1: PTP not locked: Uncalibrated"},
      cam(3, 7, true, 8),   cam(3, 8, true, -60)};
  const auto p = ptp_time_section(events, kStart, {{7, "cam0"}, {8, "cam1"}});
  ASSERT_TRUE(p);
  EXPECT_FALSE(p->contains("readings")) << "the host was not read";
  const auto& cams = (*p)["cameras"];
  ASSERT_EQ(cams.size(), 2u);
  EXPECT_EQ(cams[0]["name"], "cam0");
  EXPECT_EQ(cams[0]["readings"], 3);
  EXPECT_EQ(cams[0]["locked"], 3);
  EXPECT_DOUBLE_EQ(cams[0]["worst_offset_ns"].get<double>(), 30);
  EXPECT_EQ(cams[1]["name"], "cam1");
  EXPECT_EQ(cams[1]["locked"], 2);
  EXPECT_EQ(cams[1]["seconds_out_of_lock"], 1);
  EXPECT_DOUBLE_EQ(cams[1]["worst_offset_ns"].get<double>(), 60) << "only locked readings count";
  EXPECT_EQ(cams[1]["out_of_lock"][0]["why"], "cam1: PTP not locked: Uncalibrated");
}
}  // namespace
