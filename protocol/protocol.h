#pragma once
// A protocol file (rig-configs/protocols/*.yaml): the list of actions a participant
// performs, with the text and pictogram each is prompted with, its force levels,
// repetitions and timings; and the plan made from it for one participant: every
// action with one hand, then every action with the other, in the participant's
// hand order. Nothing assumes a count of actions. A bad file is a UserError
// naming file:line and key.
#include <filesystem>
#include <string>
#include <vector>

namespace pvcap::protocol {

enum class Force { Low, High, NoContact, Any };
const char* to_string(Force f);     // low | high | no_contact | any
const char* display_name(Force f);  // Low | High | No contact | Any force

struct Timings {
  double prompt_s = 4;     // the action shown before the countdown
  double countdown_s = 3;  // 3, 2, 1
  double record_s = 12;    // the take itself (all its repetitions)
  double rest_s = 3;       // between takes
};

// What the take check calls matching its prompt (units of the paper: N).
struct TakeCheckConfig {
  double contact_newtons = 0.5;     // Low/High/Any: the take's peak total force above this
  double no_contact_newtons = 0.3;  // No contact: the take's peak total force below this
  double high_over_low = 1.3;       // High's mean force at least this times Low's (same action, hand)
  double max_gap_ms = 250;          // no stream silent longer than this (the recording indicator's window)
};

// One row of the plan's action list (an action at one force level).
struct Action {
  std::string name;       // sequence-name stem, e.g. press_index_finger_low
  std::string group;      // the action without its force level, e.g. press_index_finger
  std::string text;       // what the participant reads
  std::string pictogram;  // SVG file, absolute
  Force force = Force::Any;
  int repetitions = 1;
  bool check_side = true;  // the hand is expected on its own half of the pad
  // Which hands perform it (both by default): a dataset's "remaining" protocol asks only for the
  // takes a participant still lacks, which may be one hand's.
  bool left_hand = true, right_hand = true;
  // The lighting its takes are recorded under (a code of the rig's lights, "L-R"; docs/lighting.md):
  // the action's `lighting:`, else the protocol's, else "" (the session's --lighting).
  std::string lighting;
  Timings timings;
  int line = 0;  // in the protocol file
};

struct Protocol {
  std::filesystem::path source;
  std::string text;  // the file's text, stored with each session
  std::string name;
  Timings timings, fast_timings;
  std::string lighting;  // the protocol's `lighting:` (every action's unless it names its own)
  TakeCheckConfig check;
  std::vector<Action> actions;  // in order; an action with several force levels is one row per level
};

Protocol load_protocol(const std::filesystem::path& file);
Protocol parse_protocol(const std::string& yaml_text, const std::filesystem::path& source);

enum class Hand { Left, Right };
const char* to_string(Hand h);

// One take to perform: an action with one hand.
struct PlannedTake {
  int step = 0;  // position in the plan, from 0
  const Action* action = nullptr;
  Hand hand = Hand::Right;
  // The PressureVisionDB sequence name: <action>_<reps>x_<hand>, retakes (2), (3)...
  std::string sequence_name(int attempt = 1) const;
};

// hand_order: right_first | left_first (anything else: right first).
std::vector<PlannedTake> make_plan(const Protocol& p, const std::string& hand_order);

}  // namespace pvcap::protocol
