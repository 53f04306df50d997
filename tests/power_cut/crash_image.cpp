#include "tests/power_cut/crash_image.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <map>
#include <random>
#include <stdexcept>

#include <fmt/format.h>

#include "tests/power_cut/trace_format.h"

namespace fs = std::filesystem;

namespace pvcap::power_cut {

Trace read_trace(const fs::path& dir) {
  Trace t;
  t.dir = dir;
  std::ifstream in(dir / "ops", std::ios::binary);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read the trace", (dir / "ops").string()));
  trace_record r{};
  while (in.read(reinterpret_cast<char*>(&r), sizeof r)) {
    if (r.magic != TRACE_MAGIC || r.path_len > 4096 || r.path2_len > 4096)
      throw std::runtime_error(
          fmt::format("{}: record {} is not a trace record", (dir / "ops").string(), t.ops.size()));
    TraceOp op;
    op.op = r.op;
    op.flags = r.flags;
    op.t_ns = r.t_ns;
    op.offset = r.offset;
    op.length = r.length;
    op.data_pos = r.data_pos;
    op.path.resize(r.path_len);
    op.path2.resize(r.path2_len);
    in.read(op.path.data(), r.path_len);
    in.read(op.path2.data(), r.path2_len);
    if (!in) throw std::runtime_error(fmt::format("{}: the last record is cut", (dir / "ops").string()));
    t.ops.push_back(std::move(op));
  }
  return t;
}

namespace {

struct Inode {
  bool folder = false;
  std::string bytes;                 // as on the disk at the last sync
  std::vector<std::size_t> pending;  // writes and truncations since
  std::int64_t last_sync = -1;       // folders: the op that last synced it
};

// A change of names. `folders` are the inodes of the folders whose entries it changes: it reached
// the disk when each of them was synced after it, or when it is in the prefix drawn for each.
struct NameChange {
  std::size_t op = 0;
  std::uint32_t kind = 0;  // TRACE_OPEN (a file made), TRACE_MKDIR, TRACE_RENAME, TRACE_UNLINK
  std::string path, path2;
  int inode = -1;
  std::vector<int> folders;
};

class Builder {
 public:
  Builder(const Trace& trace, const fs::path& root, std::uint64_t seed) : trace_(trace), root_(root), rng_(seed) {
    data_ = ::open((trace.dir / "data").c_str(), O_RDONLY | O_CLOEXEC);
    if (data_ < 0) throw std::runtime_error(fmt::format("{}: cannot read", (trace.dir / "data").string()));
    inodes_.push_back(Inode{true, {}, {}, -1});  // the root, there before the trace
    names_[root_.string()] = 0;
  }
  ~Builder() { ::close(data_); }
  Builder(const Builder&) = delete;
  Builder& operator=(const Builder&) = delete;

  void replay(std::size_t cut) {
    for (std::size_t i = 0; i < cut && i < trace_.ops.size(); ++i) apply(i);
  }

  CrashImageCounts write(const fs::path& out) {
    CrashImageCounts counts;
    // Which name changes reached the disk: those before their folders' last sync, then of the later
    // ones a random prefix per folder.
    std::map<int, std::size_t> prefix;  // folder inode -> how many of its unsynced changes were kept
    std::map<int, std::size_t> unsynced;
    for (const auto& c : changes_)
      for (int f : c.folders)
        if (std::int64_t(c.op) > inodes_[std::size_t(f)].last_sync) ++unsynced[f];
    for (const auto& [f, n] : unsynced) prefix[f] = std::uniform_int_distribution<std::size_t>(0, n)(rng_);
    std::map<int, std::size_t> seen;
    std::map<std::string, int> disk;  // path -> inode, as the disk holds the names
    disk[root_.string()] = 0;
    for (const auto& c : changes_) {
      bool after_sync = false, durable = true;
      for (int f : c.folders) {
        if (std::int64_t(c.op) <= inodes_[std::size_t(f)].last_sync) continue;
        after_sync = true;
        if (seen[f]++ >= prefix[f]) durable = false;
      }
      if (after_sync) {
        ++counts.names_after_sync;
        counts.names_kept += durable;
      }
      if (durable) apply_name(disk, c);
    }
    fs::create_directories(out);
    for (const auto& [path, inode] : disk) {
      if (path == root_.string()) continue;
      const fs::path to = out / fs::path(path).lexically_relative(root_);
      const Inode& node = inodes_[std::size_t(inode)];
      if (node.folder) {
        fs::create_directories(to);
        ++counts.folders;
        continue;
      }
      std::string bytes = node.bytes;
      for (std::size_t i : node.pending) {
        ++counts.writes_after_sync;
        const TraceOp& op = trace_.ops[i];
        const int fate = std::uniform_int_distribution<int>(0, 2)(rng_);
        if (fate == 0) {
          ++counts.dropped;
          continue;
        }
        if (op.op == TRACE_WRITE && fate == 2 && op.length > 512) {
          // Torn: its first sectors only.
          const std::int64_t sectors = std::uniform_int_distribution<std::int64_t>(0, (op.length - 1) / 512)(rng_);
          apply_data(bytes, op, sectors * 512);
          ++counts.torn;
          continue;
        }
        apply_data(bytes, op, op.length);
        ++counts.kept;
      }
      fs::create_directories(to.parent_path());
      std::ofstream f(to, std::ios::binary | std::ios::trunc);
      f.write(bytes.data(), std::streamsize(bytes.size()));
      if (!f) throw std::runtime_error(fmt::format("{}: cannot write the image", to.string()));
      ++counts.files;
    }
    return counts;
  }

 private:
  bool inside(const std::string& p) const {
    const std::string r = root_.string();
    return p == r || (p.size() > r.size() && p.compare(0, r.size(), r) == 0 && p[r.size()] == '/');
  }

  static std::string parent(const std::string& p) { return fs::path(p).parent_path().string(); }

  int folder_of(const std::string& p) {
    const auto it = names_.find(parent(p));
    return it == names_.end() ? -1 : it->second;
  }

  // The inode named `p` now, made (as if there before the trace) when the trace never saw it made.
  int inode_of(const std::string& p) {
    const auto it = names_.find(p);
    if (it != names_.end()) return it->second;
    const int id = int(inodes_.size());
    inodes_.push_back(Inode{});
    names_[p] = id;
    // As old as the trace: first of the changes, in no folder that a sync must cover.
    changes_.insert(changes_.begin(), NameChange{0, TRACE_OPEN, p, {}, id, {}});
    return id;
  }

  void note_change(std::size_t i, std::uint32_t kind, const std::string& path, const std::string& path2, int inode) {
    NameChange c{i, kind, path, path2, inode, {}};
    const int from = folder_of(path);
    if (from >= 0) c.folders.push_back(from);
    if (kind == TRACE_RENAME) {
      const int to = folder_of(path2);
      if (to >= 0 && to != from) c.folders.push_back(to);
    }
    changes_.push_back(std::move(c));
  }

  // Every name at or under `p`, moved to `to` (empty: removed).
  static void move_tree(std::map<std::string, int>& names, const std::string& p, const std::string& to) {
    std::vector<std::pair<std::string, int>> moved;
    for (auto it = names.lower_bound(p); it != names.end() && it->first.compare(0, p.size(), p) == 0;) {
      if (it->first.size() > p.size() && it->first[p.size()] != '/') {
        ++it;
        continue;
      }
      if (!to.empty()) moved.emplace_back(to + it->first.substr(p.size()), it->second);
      it = names.erase(it);
    }
    for (auto& [k, v] : moved) names[k] = v;
  }

  void apply_name(std::map<std::string, int>& names, const NameChange& c) {
    switch (c.kind) {
      case TRACE_OPEN:
      case TRACE_MKDIR:
        if (names.count(parent(c.path))) names[c.path] = c.inode;
        break;
      case TRACE_RENAME:
        if (!inside(c.path2)) {
          move_tree(names, c.path, "");
        } else if (!inside(c.path)) {
          if (names.count(parent(c.path2))) names[c.path2] = c.inode;
        } else if (names.count(c.path) && names.count(parent(c.path2))) {
          move_tree(names, c.path2, "");
          move_tree(names, c.path, c.path2);
        }
        break;
      case TRACE_UNLINK:
        move_tree(names, c.path, "");
        break;
    }
  }

  void apply_data(std::string& bytes, const TraceOp& op, std::int64_t length) const {
    if (op.op == TRACE_TRUNCATE) {
      bytes.resize(std::size_t(op.length));
      return;
    }
    if (op.op == TRACE_OPEN) {  // emptied by O_TRUNC
      bytes.clear();
      return;
    }
    if (length <= 0) return;
    const std::size_t end = std::size_t(op.offset + length);
    if (bytes.size() < end) bytes.resize(end);
    std::int64_t done = 0;
    while (done < length) {
      const ssize_t n = ::pread(data_, bytes.data() + op.offset + done, std::size_t(length - done), op.data_pos + done);
      if (n <= 0) throw std::runtime_error(fmt::format("{}: cut short", (trace_.dir / "data").string()));
      done += n;
    }
  }

  void apply(std::size_t i) {
    const TraceOp& op = trace_.ops[i];
    switch (op.op) {
      case TRACE_WRITE:
      case TRACE_TRUNCATE:
        inodes_[std::size_t(inode_of(op.path))].pending.push_back(i);
        break;
      case TRACE_SYNC: {
        // What it surely covers: the ops recorded before it began (TRACE_SYNC_FROM), or all before it.
        const std::size_t from = (op.flags & TRACE_SYNC_FROM) ? std::size_t(op.offset) : i;
        Inode& node = inodes_[std::size_t(inode_of(op.path))];
        if (node.folder) {
          node.last_sync = std::max(node.last_sync, std::int64_t(from) - 1);
          break;
        }
        std::vector<std::size_t> later;
        for (std::size_t p : node.pending)
          if (p < from)
            apply_data(node.bytes, trace_.ops[p], trace_.ops[p].length);
          else
            later.push_back(p);
        node.pending = std::move(later);
        break;
      }
      case TRACE_OPEN:
        if (op.path == root_.string()) break;
        if (op.flags & TRACE_CREATED) {
          const int id = int(inodes_.size());
          inodes_.push_back(Inode{});
          note_change(i, TRACE_OPEN, op.path, {}, id);
          names_[op.path] = id;
        } else if (op.flags & TRACE_TRUNCATED) {
          inodes_[std::size_t(inode_of(op.path))].pending.push_back(i);
        }
        break;
      case TRACE_MKDIR: {
        if (op.path == root_.string()) break;
        const int id = int(inodes_.size());
        inodes_.push_back(Inode{true, {}, {}, -1});
        note_change(i, TRACE_MKDIR, op.path, {}, id);
        names_[op.path] = id;
        break;
      }
      case TRACE_RENAME: {
        int id = -1;
        if (!inside(op.path)) {  // brought in from outside: its bytes were not traced
          id = int(inodes_.size());
          inodes_.push_back(Inode{});
        } else {
          id = inode_of(op.path);
        }
        note_change(i, TRACE_RENAME, op.path, op.path2, id);
        if (!inside(op.path2)) {
          move_tree(names_, op.path, "");
        } else if (!inside(op.path)) {
          names_[op.path2] = id;
        } else {
          move_tree(names_, op.path2, "");
          move_tree(names_, op.path, op.path2);
        }
        break;
      }
      case TRACE_UNLINK:
        note_change(i, TRACE_UNLINK, op.path, {}, -1);
        move_tree(names_, op.path, "");
        break;
      default:
        throw std::runtime_error(fmt::format("trace op {}: unknown kind {}", i, op.op));
    }
  }

  const Trace& trace_;
  fs::path root_;
  std::mt19937_64 rng_;
  int data_ = -1;
  std::vector<Inode> inodes_;
  std::map<std::string, int> names_;  // path -> inode, as the process saw them
  std::vector<NameChange> changes_;
};

}  // namespace

CrashImageCounts build_crash_image(const Trace& trace, const fs::path& root, std::size_t cut, std::uint64_t seed,
                                   const fs::path& out) {
  if (fs::exists(out)) throw std::runtime_error(fmt::format("{}: already there", out.string()));
  Builder b(trace, root.lexically_normal(), seed);
  b.replay(cut);
  return b.write(out);
}

}  // namespace pvcap::power_cut
