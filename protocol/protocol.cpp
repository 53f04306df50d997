#include "protocol/protocol.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <optional>
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

Force parse_force(const std::string& s) {  // std::invalid_argument for anything else
  if (s == "low") return Force::Low;
  if (s == "high") return Force::High;
  if (s == "no_contact") return Force::NoContact;
  if (s == "any") return Force::Any;
  throw std::invalid_argument(s);
}

// A pictogram is served to the participant's browser by the recorder (often run as root): it must
// be an image in the protocol file's own folder (or below it), never any file the path can reach.
// What is wrong with `given`, or nothing.
std::optional<std::string> pictogram_problem(const std::filesystem::path& source, const std::string& given) {
  namespace fs = std::filesystem;
  const fs::path rel(given);
  if (given.empty() || rel.is_absolute())
    return fmt::format("'{}' must be a path relative to the protocol file's folder", given);
  for (const auto& part : rel)
    if (part == "..") return fmt::format("'{}' leaves the protocol file's folder ('..')", given);
  std::string ext = rel.extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  if (ext != ".svg" && ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".webp")
    return fmt::format("'{}' is not an image (.svg, .png, .jpg or .webp)", given);
  // The error_code forms: a name the file system refuses (too long, ...) is a mistake in the file,
  // said as one, not an exception from the file system.
  std::error_code ec;
  const fs::path folder = fs::canonical(source.parent_path().empty() ? fs::path(".") : source.parent_path(), ec);
  const fs::path file = fs::canonical(source.parent_path() / rel, ec);
  if (ec || !fs::is_regular_file(file, ec))
    return fmt::format("{} does not exist{}", (source.parent_path() / rel).lexically_normal().string(),
                       ec ? " (" + ec.message() + ")" : "");
  // A symbolic link may not lead out of the folder either.
  const auto [f, _] = std::mismatch(folder.begin(), folder.end(), file.begin(), file.end());
  if (f != folder.end())
    return fmt::format("'{}' leads out of the protocol file's folder (to {})", given, file.string());
  // Its bytes must be what its name says.
  std::ifstream in(file, std::ios::binary);
  char head[16] = {};
  in.read(head, sizeof head);
  const std::string h(head, std::size_t(in.gcount()));
  const bool ok = ext == ".png"                     ? h.rfind("\x89PNG", 0) == 0
                  : ext == ".jpg" || ext == ".jpeg" ? h.rfind("\xff\xd8\xff", 0) == 0
                  : ext == ".webp" ? h.size() >= 12 && h.rfind("RIFF", 0) == 0 && h.substr(8, 4) == "WEBP"
                                   : h.find('<') != std::string::npos;
  if (!ok) return fmt::format("{} is not the image its name says", file.string());
  return std::nullopt;
}

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
  // Letters and '-' only: which letters the rig has is the session's to check (docs/lighting.md).
  const auto read_lighting = [&](MapReader& mr, const YAML::Node& node, std::string& out) {
    mr.get("lighting", out);
    if (!out.empty() && !std::all_of(out.begin(), out.end(), [](char c) { return (c >= 'A' && c <= 'Z') || c == '-'; }))
      mr.fail(node["lighting"], "lighting", fmt::format("'{}' is not a lighting code (capital letters of the rig's lights, '-' for one off: L-R)", out));
  };
  read_lighting(r, root, p.lighting);
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
    if (auto refused = pictogram_problem(source, pictogram)) ar.fail(a["pictogram"], "pictogram", *refused);
    ar.get_in_range("repetitions", base.repetitions, 1, 100);
    ar.get("check_side", base.check_side);
    base.lighting = p.lighting;
    read_lighting(ar, a, base.lighting);
    if (auto hands = ar.child("hands")) {
      if (!hands.IsSequence() || hands.size() == 0)
        ar.fail(hands, "hands", "expected a list: [left, right], [left] or [right]");
      base.left_hand = base.right_hand = false;
      for (const auto& v : hands) {
        if (v.Scalar() == "left")
          base.left_hand = true;
        else if (v.Scalar() == "right")
          base.right_hand = true;
        else
          ar.fail(v, "hands", fmt::format("'{}' is not left or right", v.Scalar()));
      }
    }
    std::vector<Force> forces;
    if (auto f = ar.child("forces")) {
      if (!f.IsSequence() || f.size() == 0) ar.fail(f, "forces", "expected a list: [low, high, no_contact] or [any]");
      for (const auto& v : f) {
        try {
          forces.push_back(parse_force(v.Scalar()));
        } catch (const std::invalid_argument&) {
          ar.fail(v, "forces", fmt::format("'{}' is not one of low, high, no_contact, any", v.Scalar()));
        }
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
    for (const auto& a : p.actions)
      if (h == Hand::Left ? a.left_hand : a.right_hand) plan.push_back({int(plan.size()), &a, h});
  return plan;
}

}  // namespace pvcap::protocol
