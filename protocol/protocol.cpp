#include "protocol/protocol.h"

#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "core/result.h"
#include "core/yaml_map_reader.h"

namespace pvcap::protocol {

const char* to_string(Force f) {
  switch (f) {
    case Force::Low:
      return "low";
    case Force::High:
      return "high";
    case Force::NoContact:
      return "no_contact";
    case Force::Any:
      return "any";
  }
  return "any";
}

const char* display_name(Force f) {
  switch (f) {
    case Force::Low:
      return "Low";
    case Force::High:
      return "High";
    case Force::NoContact:
      return "No contact";
    case Force::Any:
      return "Any force";
  }
  return "Any force";
}

const char* to_string(Hand h) { return h == Hand::Left ? "left" : "right"; }

namespace {

void read_timings(MapReader& r, Timings& t) {
  r.get_in_range("prompt_s", t.prompt_s, 0.0, 600.0);
  r.get_in_range("countdown_s", t.countdown_s, 0.0, 60.0);
  r.get_in_range("record_s", t.record_s, 0.2, 3600.0);
  r.get_in_range("rest_s", t.rest_s, 0.0, 600.0);
  r.finish();
}

bool is_name(const std::string& s) {
  if (s.empty()) return false;
  for (char c : s)
    if (!(std::islower(static_cast<unsigned char>(c)) || std::isdigit(static_cast<unsigned char>(c)) || c == '_'))
      return false;
  return true;
}

}  // namespace

Protocol parse_protocol(const std::string& text, const std::filesystem::path& source) {
  Protocol p;
  p.source = source;
  p.text = text;
  const YAML::Node root = load_yaml(text, source);
  MapReader r(root, source, "");
  r.require("name", p.name);
  if (auto t = r.child("timings")) {
    MapReader tr(t, source, "timings");
    read_timings(tr, p.timings);
  }
  p.fast_timings = {0.6, 0.6, 2.5, 0.4};
  if (auto t = r.child("fast_timings")) {
    MapReader tr(t, source, "fast_timings");
    read_timings(tr, p.fast_timings);
  }
  if (auto c = r.child("take_check")) {
    MapReader cr(c, source, "take_check");
    cr.get_in_range("contact_newtons", p.check.contact_newtons, 0.0, 1000.0);
    cr.get_in_range("no_contact_newtons", p.check.no_contact_newtons, 0.0, 1000.0);
    cr.get_in_range("high_over_low", p.check.high_over_low, 1.0, 100.0);
    cr.get_in_range("max_gap_ms", p.check.max_gap_ms, 1.0, 60000.0);
    cr.finish();
  }
  const YAML::Node actions = r.child("actions");
  if (!actions || !actions.IsSequence() || actions.size() == 0)
    r.fail(actions ? actions : root, "actions", "expected a list of actions");
  std::set<std::string> names;
  for (std::size_t i = 0; i < actions.size(); ++i) {
    const YAML::Node a = actions[i];
    MapReader ar(a, source, fmt::format("actions[{}]", i));
    Action base;
    base.line = a.Mark().line + 1;
    base.timings = p.timings;
    ar.require("name", base.group);
    if (!is_name(base.group)) ar.fail(a["name"], "name", "use lower-case letters, digits and _ (it names sequences)");
    ar.require("text", base.text);
    std::string pictogram;
    ar.require("pictogram", pictogram);
    base.pictogram = (source.parent_path() / pictogram).lexically_normal().string();
    // The error_code form: a name the file system refuses (too long, ...) is a mistake in the file,
    // said as one, not an exception from the file system.
    std::error_code missing;
    if (!std::filesystem::exists(base.pictogram, missing))
      ar.fail(a["pictogram"], "pictogram",
              fmt::format("{} does not exist{}", base.pictogram, missing ? " (" + missing.message() + ")" : ""));
    ar.get_in_range("repetitions", base.repetitions, 1, 100);
    ar.get("check_side", base.check_side);
    std::vector<Force> forces;
    if (auto f = ar.child("forces")) {
      if (!f.IsSequence() || f.size() == 0) ar.fail(f, "forces", "expected a list: [low, high, no_contact] or [any]");
      for (const auto& v : f) {
        const std::string s = v.Scalar();
        if (s == "low")
          forces.push_back(Force::Low);
        else if (s == "high")
          forces.push_back(Force::High);
        else if (s == "no_contact")
          forces.push_back(Force::NoContact);
        else if (s == "any")
          forces.push_back(Force::Any);
        else
          ar.fail(v, "forces", fmt::format("'{}' is not one of low, high, no_contact, any", s));
      }
    } else {
      forces.push_back(Force::Any);
    }
    if (auto t = ar.child("timings")) {
      MapReader tr(t, source, fmt::format("actions[{}].timings", i));
      read_timings(tr, base.timings);
    }
    ar.finish();
    for (Force f : forces) {
      Action row = base;
      row.force = f;
      row.name = f == Force::Any ? base.group : base.group + "_" + to_string(f);
      if (!names.insert(row.name).second)
        ar.fail(a, "name", fmt::format("'{}' appears twice: sequence names must be unique", row.name));
      p.actions.push_back(std::move(row));
    }
  }
  r.finish();
  return p;
}

Protocol load_protocol(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw UserError(fmt::format("{}: cannot read the protocol file", file.string()));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse_protocol(ss.str(), std::filesystem::absolute(file));
}

std::string PlannedTake::sequence_name(int attempt) const {
  std::string s = fmt::format("{}_{}x_{}", action->name, action->repetitions, to_string(hand));
  if (attempt > 1) s += fmt::format("({})", attempt);
  return s;
}

std::vector<PlannedTake> make_plan(const Protocol& p, const std::string& hand_order) {
  const Hand first = hand_order == "left_first" ? Hand::Left : Hand::Right;
  const Hand second = first == Hand::Left ? Hand::Right : Hand::Left;
  std::vector<PlannedTake> plan;
  for (Hand h : {first, second})
    for (const auto& a : p.actions) plan.push_back({int(plan.size()), &a, h});
  return plan;
}

}  // namespace pvcap::protocol
