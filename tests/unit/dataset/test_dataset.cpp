// The dataset's pure parts on hand-made catalogue rows: the completeness matrix and every QA flag,
// the remaining takes' protocol read back by the protocol parser, the splits and their leakage
// check, the catalogue's rows, the records read strictly, the release's Croissant fields.
#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "core/result.h"
#include "dataset/catalog.h"
#include "dataset/completeness.h"
#include "dataset/dataset_folder.h"
#include "dataset/release.h"
#include "dataset/splits.h"
#include "dataset/withdrawal.h"
#include "protocol/protocol.h"
#include "storage/index/catalog_db.h"

namespace fs = std::filesystem;
using json = nlohmann::json;
using namespace pvcap;
using namespace pvcap::dataset;

namespace {

// A protocol of two actions (a press at two forces, a pull): three rows, six takes a participant.
struct Folder {
  fs::path dir = fs::temp_directory_path() / fmt::format("pvcap-unit-dataset-{}", getpid());
  protocol::Protocol protocol;
  Folder() {
    fs::remove_all(dir);
    fs::create_directories(dir / "pictograms");
    fs::copy_file(fs::path(PVCAP_SOURCE_DIR) / "rig-configs/protocols/pictograms/press_index_finger.svg",
                  dir / "pictograms" / "press.svg");
    std::ofstream(dir / "protocol.yaml") << "name: two\nactions:\n"
                                            "  - {name: press, text: Press, pictogram: pictograms/press.svg, "
                                            "forces: [low, high], repetitions: 3}\n"
                                            "  - {name: pull, text: Pull, pictogram: pictograms/press.svg}\n";
    protocol = protocol::load_protocol(dir / "protocol.yaml");
  }
  ~Folder() { fs::remove_all(dir); }
};

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

CatalogSession catalog_session(const std::string& folder, const std::string& participant,
                               const json& facts = json::object(), int verify_exit = 0) {
  CatalogSession s;
  s.folder = folder;
  s.original = folder;
  s.participant = participant;
  s.skin_tone = "medium";
  s.hand_order = "right_first";
  s.lighting = "LCR";
  s.overlay = "white_vinyl";
  s.verify_exit = verify_exit;
  json f = {{"verify", {{"exit", verify_exit}, {"losses", {"an unclean end"}}, {"errors", {"video cut"}}}},
            {"streams", json::array()},
            {"self_check", json::array()},
            {"calibration", {{{"name", "cam0"}, {"pad_calibrated", true}}}}};
  f.update(facts);
  s.facts_json = f.dump();
  return s;
}

CatalogTake take(const std::string& folder, const std::string& action, const std::string& hand,
                 const std::string& status, std::optional<bool> check_ok = true) {
  CatalogTake t;
  t.folder = folder;
  t.action = action;
  t.hand = hand;
  t.sequence = action + "_x_" + hand;
  t.status = status;
  t.check_ok = check_ok;
  return t;
}

std::set<std::string> kinds(const DatasetStatus& s, const std::string& participant) {
  std::set<std::string> out;
  for (const auto& f : s.flags)
    if (f.participant == participant) out.insert(f.kind);
  return out;
}

const ParticipantStatus& of(const DatasetStatus& s, const std::string& code) {
  for (const auto& p : s.participants)
    if (p.code == code) return p;
  throw std::runtime_error("no participant " + code);
}

}  // namespace

TEST(DatasetStatus, ACellIsItsBestTakeAndWhatIsNotDoneRemainsInPlanOrder) {
  Folder f;
  DatasetConfig c;
  c.name = "t";
  const std::vector<CatalogSession> sessions = {catalog_session("/s/a", "P01")};
  const std::vector<CatalogTake> takes = {
      take("/s/a", "press_low", "right", "superseded"),  take("/s/a", "press_low", "right", "done"),
      take("/s/a", "press_high", "right", "bad", false), take("/s/a", "press_high", "right", "superseded"),
      take("/s/a", "pull", "right", "skipped"),          take("/s/a", "press_low", "left", "interrupted"),
      take("/s/a", "pull", "left", "superseded")};
  const auto s = compute_status(c, f.protocol, sessions, takes, {});
  const auto& p = of(s, "P01");
  EXPECT_EQ(p.cells.at({"right", "press_low"}).status, "done");
  EXPECT_EQ(p.cells.at({"right", "press_high"}).status, "bad");
  EXPECT_EQ(p.cells.at({"right", "pull"}).status, "missing") << "a skipped take records nothing";
  EXPECT_EQ(p.cells.at({"left", "press_low"}).status, "missing") << "an interrupted take is not a take";
  EXPECT_EQ(p.cells.at({"left", "pull"}).status, "superseded");
  const std::vector<std::pair<std::string, std::string>> remaining = {
      {"press_high", "right"}, {"pull", "right"}, {"press_low", "left"}, {"press_high", "left"}, {"pull", "left"}};
  EXPECT_EQ(p.remaining, remaining);
  EXPECT_TRUE(kinds(s, "P01").count("take_check")) << "the bad take failed its check";
}

TEST(DatasetStatus, EveryFlagFiresOnWhatItNamesAndOnlyThere) {
  Folder f;
  DatasetConfig c;
  c.name = "t";
  c.planned_participants = {"P01", "P02", "P03", "P04"};
  c.conditions = {"LCR"};
  c.thresholds.max_lost_percent = 1.0;
  c.thresholds.max_sync_offset_ms = 2.0;
  const json losses = {{"streams",
                        {{{"name", "cam0"}, {"lost_percent", 2.5}, {"not_received", 25}},
                         {{"name", "cam1"}, {"lost_percent", 0.5}, {"not_received", 5}}}}};
  const json offsets = {{"self_check",
                         {{{"name", "cam0"}, {"offset_ms", 3.5}, {"uncertainty_ms", 0.2}},
                          {{"name", "cam1"}, {"offset_ms", 3.5}, {"uncertainty_ms", 1.0}},
                          {{"name", "cam2"}, {"offset_ms", nullptr}, {"uncertainty_ms", nullptr}}}}};
  const json uncalibrated = {{"calibration", {{{"name", "cam0"}, {"pad_calibrated", false}}}}};
  auto lit_otherwise = catalog_session("/s/d", "P02");
  lit_otherwise.lighting = "L-R";
  const std::vector<CatalogSession> sessions = {
      catalog_session("/s/a", "P01", losses, 3), catalog_session("/s/b", "P01", offsets),
      catalog_session("/s/c", "P02", uncalibrated, 1), lit_otherwise, catalog_session("/s/e", "P05")};
  const std::vector<CatalogTake> takes = {take("/s/a", "pull", "left", "done"), take("/s/b", "pull", "left", "done")};
  const auto s = compute_status(c, f.protocol, sessions, takes, {});
  std::map<std::string, std::vector<std::string>> messages;
  for (const auto& x : s.flags) messages[x.participant + " " + x.kind].push_back(x.message);
  ASSERT_EQ(messages["P01 losses"].size(), 1u) << "cam1's 0.5 % is under the threshold";
  EXPECT_NE(messages["P01 losses"][0].find("cam0"), std::string::npos);
  ASSERT_EQ(messages["P01 sync_offset"].size(), 1u) << "cam1's 3.5 ms is within 2 ms + 2 x 1.0";
  EXPECT_NE(messages["P01 sync_offset"][0].find("cam0"), std::string::npos);
  ASSERT_EQ(messages["P01 not_verified_clean"].size(), 1u);
  EXPECT_NE(messages["P01 not_verified_clean"][0].find("lossy"), std::string::npos);
  ASSERT_EQ(messages["P01 duplicate_take"].size(), 1u) << "two done takes of pull, left hand";
  ASSERT_EQ(messages["P02 not_verified_clean"].size(), 1u);
  EXPECT_NE(messages["P02 not_verified_clean"][0].find("failed"), std::string::npos);
  EXPECT_EQ(messages["P02 no_calibration"].size(), 1u);
  EXPECT_EQ(messages["P02 condition_unplanned"].size(), 1u);
  EXPECT_EQ(kinds(s, "P03"), (std::set<std::string>{"no_sessions"}));
  EXPECT_EQ(kinds(s, "P05"), (std::set<std::string>{"unplanned"}));
  EXPECT_EQ(s.participants.size(), 5u);
  EXPECT_EQ(of(s, "P03").remaining.size(), 6u);

  // A withdrawn participant is in no row, no flag, no count of sessions.
  const auto w = compute_status(c, f.protocol, sessions, takes, {{"P01", "consent withdrawn", 1, {}, false}});
  EXPECT_TRUE(kinds(w, "P01").empty());
  EXPECT_EQ(w.sessions, 3u);
  EXPECT_EQ(w.withdrawn, 1u);
  for (const auto& p : w.participants) EXPECT_NE(p.code, "P01");
}

TEST(DatasetStatus, TheRemainingProtocolPlansExactlyTheMissingTakes) {
  Folder f;
  DatasetConfig c;
  c.name = "t";
  const std::vector<CatalogSession> sessions = {catalog_session("/s/a", "P01")};
  const std::vector<CatalogTake> takes = {take("/s/a", "press_low", "right", "done"),
                                          take("/s/a", "press_high", "right", "done"),
                                          take("/s/a", "press_low", "left", "done")};
  const auto s = compute_status(c, f.protocol, sessions, takes, {});
  const auto& p = of(s, "P01");
  fs::create_directories(f.dir / "remaining");
  fs::copy(f.dir / "pictograms", f.dir / "remaining" / "pictograms");
  const std::string text = remaining_protocol_yaml(f.protocol, p, "pictograms");
  ASSERT_FALSE(text.empty());
  std::ofstream(f.dir / "remaining" / "P01.yaml") << text;
  const auto rest = protocol::load_protocol(f.dir / "remaining" / "P01.yaml");
  std::vector<std::pair<std::string, std::string>> planned;
  for (const auto& t : protocol::make_plan(rest, "right_first"))
    planned.push_back({t.action->name, protocol::to_string(t.hand)});
  const std::vector<std::pair<std::string, std::string>> expected = {
      {"pull", "right"}, {"press_high", "left"}, {"pull", "left"}};
  EXPECT_EQ(planned, expected) << text;
  EXPECT_EQ(rest.actions[0].repetitions, 3) << "the protocol's repetitions carried over";
  // A complete participant has no remaining protocol.
  ParticipantStatus done = p;
  done.remaining.clear();
  EXPECT_EQ(remaining_protocol_yaml(f.protocol, done, "pictograms"), "");
}

TEST(ProtocolHands, AnActionMayNameItsHandsAndAWrongHandIsNamedAtItsLine) {
  Folder f;
  const std::string head = "name: h\nactions:\n  - {name: pull, text: Pull, pictogram: pictograms/press.svg, ";
  const auto p = protocol::parse_protocol(head + "hands: [left]}\n", f.dir / "h.yaml");
  ASSERT_EQ(protocol::make_plan(p, "right_first").size(), 1u);
  EXPECT_EQ(protocol::make_plan(p, "right_first")[0].hand, protocol::Hand::Left);
  for (const std::string bad : {"hands: [middle]}", "hands: []}", "hands: left}"}) {
    try {
      protocol::parse_protocol(head + bad + "\n", f.dir / "h.yaml");
      ADD_FAILURE() << bad << " accepted";
    } catch (const UserError& e) {
      EXPECT_NE(std::string(e.what()).find("h.yaml:3"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("hands"), std::string::npos) << e.what();
    }
  }
}

TEST(DatasetSplits, HeldOutByParticipantBalancedOverStrataAndTheSameForTheSameSeed) {
  std::vector<SplitCandidate> people;
  for (int i = 0; i < 12; ++i)
    people.push_back({fmt::format("P{:02}", i), i % 2 ? "dark" : "light", i < 6 ? "LCR" : "L-R"});
  const Splits a = make_splits(people, 4, 4, 42), b = make_splits(people, 4, 4, 42);
  EXPECT_EQ(a.train, b.train);
  EXPECT_EQ(a.test, b.test);
  EXPECT_EQ(a.test.size(), 4u);
  EXPECT_EQ(a.val.size(), 4u);
  EXPECT_EQ(a.train.size(), 4u);
  std::map<std::string, int> seen;
  for (const auto* v : {&a.train, &a.val, &a.test})
    for (const auto& c : *v) ++seen[c];
  EXPECT_EQ(seen.size(), 12u);
  for (const auto& [c, n] : seen) EXPECT_EQ(n, 1) << c;
  // Four strata of three: the test set takes one from each.
  std::map<std::string, int> test_strata;
  for (const auto& c : a.test) {
    const int i = std::stoi(c.substr(1));
    ++test_strata[fmt::format("{}/{}", i % 2, i < 6)];
  }
  EXPECT_EQ(test_strata.size(), 4u);
  bool another_seed_differs = false;
  for (std::uint64_t seed = 1; seed < 6; ++seed) another_seed_differs |= make_splits(people, 4, 4, seed).test != a.test;
  EXPECT_TRUE(another_seed_differs);
  EXPECT_THROW(make_splits(people, 6, 6, 1), UserError);
  EXPECT_TRUE(leakage_problems(a, {}, {}).empty());
}

TEST(DatasetSplits, TheLeakageCheckNamesEachWayAParticipantCanLeak) {
  Splits s;
  s.train = {"P01", "P02"};
  s.test = {"P02", "P03"};
  std::vector<CatalogSession> sessions = {catalog_session("/s/a", "P01"), catalog_session("/s/b", "P04"),
                                          catalog_session("/s/c", "P05")};
  sessions[2].original = "/s/b";  // a continuation of P04's session recorded under another code
  const auto problems = leakage_problems(s, sessions, {{"P03", "withdrew", 1, {}, false}});
  std::string all;
  for (const auto& p : problems) all += p + "\n";
  EXPECT_NE(all.find("P02 is in 2 splits"), std::string::npos) << all;
  EXPECT_NE(all.find("P03 withdrew"), std::string::npos) << all;
  EXPECT_NE(all.find("continues under 2 participants"), std::string::npos) << all;
  EXPECT_NE(all.find("P04 is in no split"), std::string::npos) << all;
  EXPECT_EQ(problems.size(), 5u) << all << "(P05 is in no split either)";
}

TEST(DatasetCatalogue, RowsRoundTripAFolderNoLongerFoundIsForgottenAndAnotherVersionIsRebuilt) {
  Folder f;
  const fs::path file = f.dir / "catalog.db";
  {
    auto db = CatalogDb::open(file);
    ASSERT_TRUE(db) << db.error().message;
    auto s = catalog_session("/s/a", "P01");
    s.fingerprint = "session.db:10:1.0;";
    ASSERT_TRUE(db.value()->put(s, {take("/s/a", "pull", "left", "done", std::nullopt)}).ok());
    ASSERT_TRUE(db.value()->put(catalog_session("/s/b", "P02"), {take("/s/b", "pull", "right", "bad", false)}).ok());
    EXPECT_EQ(db.value()->fingerprint("/s/a"), "session.db:10:1.0;");
    EXPECT_FALSE(db.value()->fingerprint("/s/z"));
    const auto takes = db.value()->takes();
    ASSERT_EQ(takes.size(), 2u);
    EXPECT_FALSE(takes[0].check_ok);
    EXPECT_EQ(takes[1].check_ok, std::optional<bool>(false));
    ASSERT_TRUE(db.value()->put(s, {}).ok());  // read again: its takes replaced
    EXPECT_EQ(db.value()->takes().size(), 1u);
    const auto removed = db.value()->remove_except({"/s/b"});
    ASSERT_TRUE(removed);
    EXPECT_EQ(removed.value(), 1u);
    ASSERT_EQ(db.value()->sessions().size(), 1u);
    EXPECT_EQ(db.value()->sessions()[0].participant, "P02");
  }
  ASSERT_EQ(std::system(fmt::format("sqlite3 {} 'PRAGMA user_version = 99'", file.string()).c_str()), 0);
  auto db = CatalogDb::open(file);
  ASSERT_TRUE(db);
  EXPECT_TRUE(db.value()->sessions().empty()) << "another version's catalogue is rebuilt from the sessions";
  std::ofstream(f.dir / "bad.db") << "not a database";
  auto bad = CatalogDb::open(f.dir / "bad.db");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("bad.db"), std::string::npos);
}

TEST(DatasetRecords, AKeyOfTheWrongTypeIsNamedWithItsFile) {
  const fs::path file = "/d/withdrawals.json";
  try {
    parse_withdrawals(json::parse(R"([{"participant": 7}])"), file);
    ADD_FAILURE();
  } catch (const UserError& e) {
    EXPECT_NE(std::string(e.what()).find("/d/withdrawals.json: 'participant' is not text"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(parse_releases(json::parse(R"({"out": "/r"})"), "/d/releases.json"), UserError);
  EXPECT_THROW(splits_from_json(json::parse(R"({"train": "P01"})"), "/d/splits.json"), UserError);
  const auto w = parse_withdrawals(json::parse(R"([{"participant": "P02", "reason": "r", "wall_ns": 5}])"), file);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_TRUE(is_withdrawn(w, "P02"));
  EXPECT_FALSE(is_withdrawn(w, "P01"));
}

TEST(DatasetRelease, TheCroissantMetadataHoldsTheFieldsItsSpecificationRequires) {
  DatasetConfig c;
  c.name = "lab";
  c.license = "https://creativecommons.org/licenses/by-nc/4.0/";
  c.url = "https://example.org/lab";
  c.creators = {"A", "B"};
  ReleasePlan plan;
  plan.layout = "pressurevision";
  const json m = croissant_metadata(c, plan, "2026-11-25", "aa", "bb");
  for (const char* key :
       {"@context", "@type", "conformsTo", "description", "license", "name", "url", "creator", "datePublished"})
    EXPECT_TRUE(m.contains(key)) << key;
  EXPECT_EQ(m["@type"], "sc:Dataset");
  EXPECT_EQ(m["conformsTo"], "http://mlcommons.org/croissant/1.0");
  EXPECT_EQ(m["creator"].size(), 2u);
  std::set<std::string> ids;
  for (const auto& d : m["distribution"]) {
    EXPECT_TRUE(ids.insert(d["@id"].get<std::string>()).second) << "ids are unique";
    if (d["@type"] == "cr:FileObject") {
      EXPECT_TRUE(d.contains("sha256") && d.contains("contentUrl"));
    } else {
      EXPECT_TRUE(d.contains("includes") && d.contains("encodingFormat"));
    }
  }
  EXPECT_EQ(m["recordSet"][0]["field"].size(), 3u);
}

// A release lacking what its metadata requires is refused before any export, naming each missing key.
TEST(DatasetRelease, MissingLicenceUrlOrCreatorsAreNamedBeforeAnyExport) {
  DatasetConfig c;
  c.dir = "/lab/dataset";
  c.url = "https://example.org/lab";
  const Status s = check_release_metadata(c);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("/lab/dataset/dataset.yaml: set license, creators before a release"),
            std::string::npos)
      << s.error().message;
  EXPECT_NE(s.error().message.find("nothing was exported"), std::string::npos);
  c.license = "https://creativecommons.org/licenses/by-nc/4.0/";
  c.creators = {"A"};
  EXPECT_TRUE(check_release_metadata(c).ok());
}

TEST(DatasetRelease, APlansFoldersAreFixedBeforeAnyJobRunsAndASecondTakeOfANameIsTheSecondFolder) {
  Folder f;
  std::vector<CatalogSession> sessions = {catalog_session("/s/a", "P01"), catalog_session("/s/b", "P01"),
                                          catalog_session("/s/c", "P02")};
  sessions[0].started_wall_ns = 1;
  sessions[1].started_wall_ns = 2;
  auto at = [](CatalogTake t, int step, std::int64_t start) {
    t.step = step;
    t.start_ns = start;
    return t;
  };
  const std::vector<CatalogTake> takes = {
      at(take("/s/a", "pull", "left", "done"), 0, 100), at(take("/s/a", "pull", "right", "superseded"), 1, 150),
      at(take("/s/b", "pull", "left", "done"), 0, 200), at(take("/s/c", "pull", "left", "done"), 0, 300)};
  const fs::path out = f.dir / "release";
  auto plan = prepare_release(f.dir, sessions, takes, {{"P02", "withdrew", 1, {}, false}}, out, "pressurevision");
  ASSERT_TRUE(plan) << plan.error().message;
  EXPECT_EQ(plan.value().sessions, (std::vector<std::string>{"/s/a", "/s/b"}));
  EXPECT_EQ(plan.value().participants, (std::vector<std::string>{"P01"}));
  const auto& names = plan.value().sequence_folders;
  EXPECT_EQ(names.at("/s/a").at("0:100"), "pull_x_left");
  EXPECT_EQ(names.at("/s/a").count("1:150"), 0u) << "only done takes are released";
  EXPECT_EQ(names.at("/s/b").at("0:200"), "pull_x_left(2)");
  EXPECT_EQ(dataset::read_json_file(out / "participants.json", nullptr), json({{"P01", "0001_P01"}}));
  // The plan is read back as written; another plan into the same folder is refused.
  auto loaded = load_plan(f.dir, out);
  ASSERT_TRUE(loaded) << loaded.error().message;
  EXPECT_EQ(loaded.value().sequence_folders, names);
  EXPECT_TRUE(prepare_release(f.dir, sessions, takes, {{"P02", "withdrew", 1, {}, false}}, out, "pressurevision"));
  auto other = prepare_release(f.dir, sessions, takes, {}, out, "pressurevision");
  ASSERT_FALSE(other);
  EXPECT_NE(other.error().message.find("other sessions"), std::string::npos) << other.error().message;
  EXPECT_EQ(pending_jobs(loaded.value()).size(), 2u);
}

TEST(DatasetCatalogue, AFolderThatCannotBeReadIsCataloguedAsFailedNotLeftOut) {
  Folder f;
  fs::create_directories(f.dir / "sessions" / "20261125-000000_rig");
  std::ofstream(f.dir / "sessions" / "20261125-000000_rig" / "session.db") << "not a session index";
  DatasetConfig c;
  c.dir = f.dir;
  c.name = "t";
  c.session_roots = {f.dir / "sessions"};
  auto db = CatalogDb::open(f.dir / "catalog.db");
  ASSERT_TRUE(db);
  std::atomic<bool> stop{false};
  auto r = scan(c, *db.value(), nullptr, stop);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r.value().found, 1u);
  ASSERT_EQ(r.value().problems.size(), 1u);
  EXPECT_NE(r.value().problems[0].find("cannot be read"), std::string::npos) << r.value().problems[0];
  const auto sessions = db.value()->sessions();
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0].verify_exit, 1);
  const auto s = compute_status(c, f.protocol, sessions, {}, {});
  EXPECT_TRUE(kinds(s, "unrecorded").count("not_verified_clean"));
  // Unchanged, it is not read again.
  auto again = scan(c, *db.value(), nullptr, stop);
  ASSERT_TRUE(again);
  EXPECT_EQ(again.value().unchanged, 1u);
  EXPECT_TRUE(again.value().problems.empty());
}

// A withdrawal: refused for a code that is not one, a participant not in the dataset and one who
// withdrew already (nothing written); otherwise the record, the splits without them, and, purged,
// their folder out of each release that holds them (participants.json and SHA256SUMS rewritten,
// the other participants' files untouched) and their session folders deleted.
TEST(DatasetWithdraw, WhatItRefusesWritesAndDeletes) {
  Folder f;
  DatasetConfig c;
  c.dir = f.dir;
  c.name = "lab";
  const fs::path out = f.dir / "release-1", s1 = f.dir / "sessions" / "a", s2 = f.dir / "sessions" / "b";
  for (const auto& d : {out / "0001_P01" / "take", out / "0002_P02" / "take", s1, s2}) fs::create_directories(d);
  std::ofstream(out / "0001_P01" / "take" / "x.jpg") << "p01";
  std::ofstream(out / "0002_P02" / "take" / "x.jpg") << "p02";
  std::ofstream(out / "participants.json") << R"({"P01": "0001_P01", "P02": "0002_P02"})";
  ASSERT_TRUE(write_sha256sums(out));
  ASSERT_TRUE(record_release(f.dir, {out.string(), 1, {"P01", "P02"}}).ok());
  std::ofstream(f.dir / "splits.json") << R"({"seed": 3, "train": ["P01"], "val": [], "test": ["P02"]})";
  const std::vector<CatalogSession> sessions = {catalog_session(s1.string(), "P01"),
                                                catalog_session(s2.string(), "P02")};
  const std::vector<std::string> participants = {"P01", "P02"};

  for (const auto& [code, said] : std::vector<std::pair<std::string, std::string>>{
           {"P 01", "'P 01' is not a participant code"},
           {"P09", "no participant P09 in dataset lab (participants: P01, P02)"}}) {
    auto refused = withdraw(c, participants, sessions, {code, "asked", true, 1});
    ASSERT_FALSE(refused);
    EXPECT_NE(refused.error().message.find(said), std::string::npos) << refused.error().message;
  }
  EXPECT_FALSE(fs::exists(f.dir / "withdrawals.json")) << "a refusal writes nothing";

  auto done = withdraw(c, participants, sessions, {"P01", "asked", true, 2});
  ASSERT_TRUE(done) << done.error().message;
  const WithdrawReport& r = done.value();
  EXPECT_EQ(r.session_folders, std::vector<std::string>{s1.string()});
  ASSERT_EQ(r.releases.size(), 1u);
  EXPECT_EQ(r.releases[0].folder, "0001_P01");
  EXPECT_TRUE(r.releases[0].removed);
  EXPECT_TRUE(r.splits_rewritten && r.sessions_removed);
  EXPECT_FALSE(fs::exists(out / "0001_P01"));
  EXPECT_FALSE(fs::exists(s1));
  EXPECT_TRUE(fs::exists(out / "0002_P02" / "take" / "x.jpg")) << "another participant's files stay";
  EXPECT_TRUE(fs::exists(s2));
  const std::string sums = read_all(out / "SHA256SUMS");
  EXPECT_EQ(sums.find("0001_P01"), std::string::npos) << sums;
  EXPECT_NE(sums.find("0002_P02"), std::string::npos) << sums;
  EXPECT_EQ(read_all(out / "participants.json").find("P01"), std::string::npos);
  EXPECT_EQ(read_all(f.dir / "splits.json").find("P01"), std::string::npos);
  EXPECT_TRUE(is_withdrawn(load_withdrawals(f.dir), "P01"));

  auto again = withdraw(c, participants, sessions, {"P01", "asked", true, 3});
  ASSERT_FALSE(again);
  EXPECT_NE(again.error().message.find("P01 has withdrawn already"), std::string::npos) << again.error().message;

  // Without --purge: the record and the splits only; every file stays.
  auto kept = withdraw(c, participants, sessions, {"P02", "asked", false, 4});
  ASSERT_TRUE(kept) << kept.error().message;
  EXPECT_FALSE(kept.value().releases.at(0).removed);
  EXPECT_FALSE(kept.value().sessions_removed);
  EXPECT_TRUE(fs::exists(out / "0002_P02" / "take" / "x.jpg"));
  EXPECT_TRUE(fs::exists(s2));
}

// The lighting the images saw (docs/lighting.md): a session labelled one lighting whose images show
// another, and a take recorded under another lighting than commanded, are each flagged
// condition_mismatch; the participant's condition (what the splits stratify by) is the measured one;
// the catalogue keeps both per take.
TEST(DatasetStatus, WhatTheImagesSawIsTheConditionAndADisagreementIsFlagged) {
  Folder f;
  DatasetConfig c;
  c.name = "t";
  auto labelled_otherwise = catalog_session("/s/a", "P01");  // labelled LCR
  labelled_otherwise.lighting_seen = "L-R";
  auto agrees = catalog_session("/s/b", "P02");
  agrees.lighting_seen = "LCR";
  auto unmeasured = catalog_session("/s/c", "P03");  // a rig without lights: its label stands
  auto dark_take = take("/s/b", "pull", "right", "done", false);
  dark_take.lighting_commanded = "-C-";
  dark_take.lighting_seen = "---";
  auto lit_take = take("/s/b", "pull", "left", "done");
  lit_take.lighting_commanded = "L-R";
  lit_take.lighting_seen = "LR";  // the same lights, in another form
  const auto s = compute_status(c, f.protocol, {labelled_otherwise, agrees, unmeasured}, {dark_take, lit_take}, {});
  std::map<std::string, std::vector<std::string>> messages;
  for (const auto& x : s.flags) messages[x.participant + " " + x.kind].push_back(x.message);
  ASSERT_EQ(messages["P01 condition_mismatch"].size(), 1u);
  EXPECT_EQ(messages["P01 condition_mismatch"][0], "labelled lighting 'LCR', but its images show L-R (docs/lighting.md)");
  ASSERT_EQ(messages["P02 condition_mismatch"].size(), 1u) << "one take; the other saw its own lights";
  EXPECT_EQ(messages["P02 condition_mismatch"][0],
            "1 take(s) recorded under another lighting than commanded (pull_x_right: -C- commanded, --- seen)");
  EXPECT_FALSE(messages.count("P03 condition_mismatch"));
  EXPECT_EQ(of(s, "P01").lighting, std::vector<std::string>{"L-R"});
  EXPECT_EQ(of(s, "P02").lighting, std::vector<std::string>{"LCR"});
  EXPECT_EQ(of(s, "P03").lighting, std::vector<std::string>{"LCR"});
  // The catalogue keeps what was measured, per session and per take.
  auto db = CatalogDb::open(f.dir / "catalog.db");
  ASSERT_TRUE(db) << db.error().message;
  ASSERT_TRUE(db.value()->put(agrees, {dark_take}).ok());
  EXPECT_EQ(db.value()->sessions()[0].lighting_seen, "LCR");
  EXPECT_EQ(db.value()->takes()[0].lighting_commanded, "-C-");
  EXPECT_EQ(db.value()->takes()[0].lighting_seen, "---");
}
