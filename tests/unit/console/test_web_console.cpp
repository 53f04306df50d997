// The session's pages: which addresses count as loopback, what binding refuses, and the URLs
// printed for the operator. (Served pages are tested end to end in integration/test_session_pages.)
#include <gtest/gtest.h>

#include "console/web_console.h"

using namespace pvcap::console;
using namespace pvcap::protocol;

TEST(WebConsole, OnlyLoopbackAddressesServeWithoutAToken) {
  EXPECT_TRUE(is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(is_loopback_address("127.4.5.6"));
  EXPECT_TRUE(is_loopback_address("::1"));
  EXPECT_TRUE(is_loopback_address("localhost"));
  EXPECT_FALSE(is_loopback_address("0.0.0.0"));
  EXPECT_FALSE(is_loopback_address("10.0.0.7"));
  EXPECT_FALSE(is_loopback_address("128.0.0.1"));
  EXPECT_FALSE(is_loopback_address("::"));
  EXPECT_FALSE(is_loopback_address("lab-pc"));
}

TEST(WebConsole, ABadAddressIsRefusedWithWhatWasGiven) {
  auto w = WebConsole::bind({.bind = "lab pc", .port = 0});
  ASSERT_FALSE(w);
  EXPECT_NE(w.error().message.find("--web-bind 'lab pc' is not an IP address"), std::string::npos);
}

TEST(WebConsole, LoopbackTooHasATokenInThePrintedAddressUnlessRefusedOnPurpose) {
  auto generated = WebConsole::bind({.bind = "127.0.0.1", .port = 0});
  ASSERT_TRUE(generated) << generated.error().message;
  EXPECT_EQ(generated.value()->token().size(), 32u);
  EXPECT_GT(generated.value()->port(), 0);
  EXPECT_EQ(generated.value()->url("participant"), "http://127.0.0.1:" + std::to_string(generated.value()->port()) +
                                                       "/participant?token=" + generated.value()->token());

  auto open = WebConsole::bind({.bind = "127.0.0.1", .port = 0, .no_token = true});
  ASSERT_TRUE(open) << open.error().message;
  EXPECT_TRUE(open.value()->token().empty());
  EXPECT_EQ(open.value()->url("participant"),
            "http://127.0.0.1:" + std::to_string(open.value()->port()) + "/participant");
  auto off_loopback = WebConsole::bind({.bind = "10.231.0.1", .port = 0, .no_token = true});
  ASSERT_FALSE(off_loopback);
  EXPECT_NE(off_loopback.error().message.find("loopback only"), std::string::npos) << off_loopback.error().message;

  auto guarded = WebConsole::bind({.bind = "127.0.0.1", .port = 0, .token = "s3cret-token"});
  ASSERT_TRUE(guarded);
  EXPECT_EQ(guarded.value()->url("operator"),
            "http://127.0.0.1:" + std::to_string(guarded.value()->port()) + "/operator?token=s3cret-token");
}

TEST(WebConsole, ABusyPortFallsBackToAFreeOne) {
  auto first = WebConsole::bind({.bind = "127.0.0.1", .port = 0});
  ASSERT_TRUE(first);
  auto second = WebConsole::bind({.bind = "127.0.0.1", .port = first.value()->port()});
  ASSERT_TRUE(second) << second.error().message;
  EXPECT_NE(second.value()->port(), first.value()->port());
}
