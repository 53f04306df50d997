#include <gtest/gtest.h>

#include <set>

#include "core/result.h"
#include "protocol/protocol.h"

using namespace pvcap;
using namespace pvcap::protocol;

namespace {
const std::filesystem::path kDefault =
    std::filesystem::path(PVCAP_SOURCE_DIR) / "rig-configs/protocols/pressurevision.yaml";

std::string error_of(const std::string& yaml) {
  try {
    parse_protocol(yaml, kDefault);
  } catch (const UserError& e) {
    return e.what();
  }
  return "";
}
}  // namespace

TEST(ProtocolFile, TheDefaultIsThePapersTableOf35Rows) {
  const Protocol p = load_protocol(kDefault);
  ASSERT_EQ(p.actions.size(), 35u);
  EXPECT_EQ(p.actions.front().name, "calibration");
  EXPECT_EQ(p.actions.front().repetitions, 1);
  std::map<Force, int> by_force;
  std::set<std::string> groups;
  for (const auto& a : p.actions) {
    ++by_force[a.force];
    groups.insert(a.group);
    EXPECT_TRUE(std::filesystem::exists(a.pictogram)) << a.pictogram;
    EXPECT_FALSE(a.text.empty());
  }
  // Six actions at Low, High and No contact; two more at Low and High only.
  EXPECT_EQ(by_force[Force::Low], 8);
  EXPECT_EQ(by_force[Force::High], 8);
  EXPECT_EQ(by_force[Force::NoContact], 6);
  EXPECT_EQ(by_force[Force::Any], 13);
  EXPECT_EQ(groups.size(), 21u);
}

TEST(ProtocolFile, ThePlanDoesEveryActionWithOneHandThenTheOther) {
  const Protocol p = load_protocol(kDefault);
  const auto plan = make_plan(p, "left_first");
  ASSERT_EQ(plan.size(), 70u);
  for (std::size_t i = 0; i < plan.size(); ++i) {
    EXPECT_EQ(plan[i].step, int(i));
    EXPECT_EQ(plan[i].hand, i < 35 ? Hand::Left : Hand::Right);
    EXPECT_EQ(plan[i].action, &p.actions[i % 35]);
  }
  EXPECT_EQ(plan[1].sequence_name(), "press_index_finger_low_5x_left");
  EXPECT_EQ(plan[38].sequence_name(2), "press_index_finger_no_contact_5x_right(2)");
  EXPECT_EQ(make_plan(p, "right_first")[0].hand, Hand::Right);
}

TEST(ProtocolFile, MistakesAreNamedWithTheirLine) {
  const std::string head = "name: t\nactions:\n";
  EXPECT_NE(
      error_of(head + "  - name: a\n    text: x\n    pictogram: pictograms/press_palm.svg\n    forces: [low, hard]\n")
          .find(":6: actions[0].forces: 'hard' is not one of"),
      std::string::npos);
  EXPECT_NE(error_of(head + "  - name: a\n    text: x\n    pictogram: nothing.svg\n").find(":5: actions[0].pictogram"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - name: A b\n    text: x\n    pictogram: pictograms/press_palm.svg\n")
                .find("actions[0].name: use lower-case"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - {name: a, text: x, pictogram: pictograms/press_palm.svg, repetition: 5}\n")
                .find("unknown key"),
            std::string::npos);
  EXPECT_NE(error_of(head + "  - {name: a, text: x, pictogram: pictograms/press_palm.svg}\n"
                            "  - {name: a, text: y, pictogram: pictograms/press_palm.svg}\n")
                .find("'a' appears twice"),
            std::string::npos);
  EXPECT_NE(error_of("name: t\nactions: []\n").find("expected a list of actions"), std::string::npos);
  EXPECT_NE(error_of("name: [t\n").find("YAML syntax error"), std::string::npos);
}
