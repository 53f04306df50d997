#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
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

// The recorder serves each pictogram to the participant's browser: only images inside the protocol
// file's folder are taken, and anything else is refused at load with file:line.
TEST(ProtocolFile, PictogramsAreImagesInsideTheProtocolsFolder) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("pvcap-pictograms-" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "img");
  std::ofstream(dir / "img" / "ok.svg") << "<svg xmlns='http://www.w3.org/2000/svg'/>";
  std::ofstream(dir / "img" / "fake.png") << "not a png at all";
  std::ofstream(dir / "notes.txt") << "hello";
  fs::create_symlink("/etc/hostname", dir / "img" / "link.svg");
  auto load_error = [&](const std::string& pictogram) {
    std::ofstream(dir / "p.yaml") << "name: t\nactions:\n  - name: a\n    text: x\n    pictogram: " << pictogram
                                  << "\n";
    try {
      load_protocol(dir / "p.yaml");
    } catch (const UserError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(load_error("img/ok.svg"), "");
  const std::string at = (dir / "p.yaml").string() + ":5: actions[0].pictogram";
  for (const auto& [pictogram, why] :
       std::vector<std::pair<std::string, std::string>>{{"/etc/passwd", "relative to the protocol file's folder"},
                                                        {"../../etc/hostname.svg", "leaves the protocol file's folder"},
                                                        {"img/../../x.svg", "leaves the protocol file's folder"},
                                                        {"notes.txt", "is not an image"},
                                                        {"img/fake.png", "is not the image its name says"},
                                                        {"img/link.svg", "leads out of the protocol file's folder"},
                                                        {"img/missing.svg", "does not exist"}}) {
    const std::string e = load_error(pictogram);
    EXPECT_EQ(e.rfind(at, 0), 0u) << pictogram << ": " << e;
    EXPECT_NE(e.find(why), std::string::npos) << pictogram << ": " << e;
  }
  fs::remove_all(dir);
}

// `lighting:` on the protocol is every action's unless an action names its own; it must be a code.
TEST(ProtocolFile, LightingIsTheProtocolsUnlessAnActionNamesItsOwn) {
  const Protocol p = parse_protocol(
      "name: lit\nlighting: LCR\nactions:\n"
      "  - {name: a, text: A, pictogram: pictograms/press_palm.svg}\n"
      "  - {name: b, text: B, pictogram: pictograms/press_palm.svg, lighting: L-R, forces: [low, high]}\n",
      kDefault);
  ASSERT_EQ(p.actions.size(), 3u);
  EXPECT_EQ(p.lighting, "LCR");
  EXPECT_EQ(p.actions[0].lighting, "LCR");
  EXPECT_EQ(p.actions[1].lighting, "L-R");
  EXPECT_EQ(p.actions[2].lighting, "L-R");
  EXPECT_EQ(load_protocol(kDefault).actions[0].lighting, "") << "the paper's protocol leaves it to the session";
  EXPECT_NE(error_of("name: x\nactions:\n  - {name: a, text: A, pictogram: pictograms/press_palm.svg, lighting: l1}\n")
                .find("actions[0].lighting: 'l1' is not a lighting code"),
            std::string::npos);
}
