#include "recording/bag_tf.hpp"

#include <algorithm>
#include <fmt/format.h>
#include <map>
#include <optional>
#include <set>

#include "core/errors.hpp"

namespace insalign::io {

namespace {

constexpr std::size_t kMaxDepth = 256;  // a longer parent chain is a cycle

struct Edge {
  std::string parent;
  bool moving = false;
  std::vector<std::pair<double, Iso3>> samples;  ///< T_parent_child, time order
};
using Tree = std::map<std::string, Edge>;  ///< by child frame

std::string frame_name(std::string name) {
  while (!name.empty() && name.front() == '/') name.erase(name.begin());
  return name;
}

void add(Tree& tree, const bag::TransformStamped& tf, bool moving, const std::string& source,
         std::set<std::string>& conflicts) {
  const std::string child = frame_name(tf.child_frame_id), parent = frame_name(tf.header.frame_id);
  Edge& e = tree[child];
  if (e.samples.empty()) e.parent = parent, e.moving = moving;
  if (e.parent != parent || e.moving != moving) {
    conflicts.insert(child);  // TF allows one parent per frame: keep the first
    return;
  }
  const Iso3 T = bag::transform_from(tf, source);
  if (moving) {
    e.samples.emplace_back(tf.header.stamp.seconds(), T);
  } else {
    e.samples.assign(1, {tf.header.stamp.seconds(), T});  // the latest static value holds
  }
}

Tree build_tree(const std::vector<bag::TransformStamped>& moving, const std::vector<bag::TransformStamped>& fixed,
                const std::string& source, std::vector<std::string>& warnings) {
  Tree tree;
  std::set<std::string> conflicts;
  for (const auto& tf : fixed) add(tree, tf, false, source, conflicts);
  for (const auto& tf : moving) add(tree, tf, true, source, conflicts);
  for (auto& [child, e] : tree) {
    std::stable_sort(e.samples.begin(), e.samples.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    e.samples.erase(std::unique(e.samples.begin(), e.samples.end(),
                                [](const auto& a, const auto& b) { return b.first - a.first < 1e-9; }),
                    e.samples.end());
  }
  for (const std::string& c : conflicts) {
    warnings.push_back(fmt::format("TF: frame '{}' has transforms from more than one parent (or both in /tf and "
                                   "/tf_static); kept those from '{}'",
                                   c, tree[c].parent));
  }
  return tree;
}

std::vector<std::string> ancestors(const Tree& tree, const std::string& frame, const std::string& source) {
  std::vector<std::string> out{frame};
  for (auto it = tree.find(frame); it != tree.end(); it = tree.find(out.back())) {
    out.push_back(it->second.parent);
    if (out.size() > kMaxDepth) throw InputError(source, "", "TF: the transforms form a cycle through '" + frame + "'");
  }
  return out;
}

std::string describe_tree(const Tree& tree) {
  std::string out;
  for (const auto& [child, e] : tree) {
    out += (out.empty() ? "" : ", ") + e.parent + " -> " + child +
           (e.moving ? fmt::format(" ({} stamps)", e.samples.size()) : std::string(" (static)"));
  }
  return out.empty() ? "(no transforms)" : out;
}

// The end of the moving chain: moved by /tf, moving nothing itself (below `world`, if given).
std::string obvious_ins_frame(const Tree& tree, const std::string& world, const std::string& source) {
  std::set<std::string> moving_parents;
  for (const auto& [child, e] : tree) {
    if (e.moving) moving_parents.insert(e.parent);
  }
  std::vector<std::string> ends;
  for (const auto& [child, e] : tree) {
    if (!e.moving || moving_parents.count(child) > 0) continue;
    const auto up = ancestors(tree, child, source);
    if (world.empty() || std::find(up.begin(), up.end(), world) != up.end()) ends.push_back(child);
  }
  if (ends.size() == 1) return ends.front();
  std::string list;
  for (const std::string& f : ends) list += (list.empty() ? "" : ", ") + f;
  throw InputError(source, "",
                   fmt::format("TF: {}; give --world-frame and --ins-frame. Transforms: {}",
                               ends.empty() ? std::string("no frame is moved by /tf") + (world.empty() ? "" : " below '" + world + "'")
                                            : "the moving transforms end in several frames (" + list + ")",
                               describe_tree(tree)));
}

Iso3 interpolate(const Iso3& a, const Iso3& b, double s) {
  Iso3 T = Iso3::Identity();
  T.linear() = Eigen::Quaterniond(a.linear()).slerp(s, Eigen::Quaterniond(b.linear())).toRotationMatrix();
  T.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return T;
}

std::optional<Iso3> edge_at(const Edge& e, double t_s) {
  if (!e.moving) return e.samples.front().second;
  const auto& s = e.samples;
  constexpr double kSlack_s = 1e-9;
  if (t_s < s.front().first - kSlack_s || t_s > s.back().first + kSlack_s) return std::nullopt;
  auto hi = std::lower_bound(s.begin(), s.end(), t_s, [](const auto& p, double t) { return p.first < t; });
  if (hi == s.end()) return s.back().second;
  if (hi == s.begin() || hi->first - t_s < kSlack_s) return hi->second;
  const auto lo = hi - 1;
  return interpolate(lo->second, hi->second, (t_s - lo->first) / (hi->first - lo->first));
}

// T_top_frame along `up` (frame first) from up[0] to up[n].
std::optional<Iso3> compose_up(const Tree& tree, const std::vector<std::string>& up, std::size_t n, double t_s) {
  Iso3 T = Iso3::Identity();
  for (std::size_t k = n; k-- > 0;) {
    const auto e = edge_at(tree.at(up[k]), t_s);
    if (!e) return std::nullopt;
    T = T * *e;
  }
  return T;
}

void require_frame(const Tree& tree, const std::string& frame, const char* option, const std::string& source) {
  for (const auto& [child, e] : tree) {
    if (child == frame || e.parent == frame) return;
  }
  throw InputError(source, "", fmt::format("TF: {} '{}' is not a frame of /tf or /tf_static. Transforms: {}", option,
                                           frame, describe_tree(tree)));
}

}  // namespace

TfChain tf_chain(const std::vector<bag::TransformStamped>& moving, const std::vector<bag::TransformStamped>& fixed,
                 const std::string& world_frame, const std::string& ins_frame, const std::string& source) {
  TfChain out;
  const Tree tree = build_tree(moving, fixed, source, out.warnings);
  const std::string world_given = frame_name(world_frame);
  if (!world_given.empty()) require_frame(tree, world_given, "--world-frame", source);
  out.ins_frame = ins_frame.empty() ? obvious_ins_frame(tree, world_given, source) : frame_name(ins_frame);
  require_frame(tree, out.ins_frame, "--ins-frame", source);
  const std::vector<std::string> up_ins = ancestors(tree, out.ins_frame, source);
  out.world_frame = world_given.empty() ? up_ins.back() : world_given;
  if (out.world_frame == out.ins_frame) throw InputError(source, "", "TF: the world and ins frames are the same frame");
  const std::vector<std::string> up_world = ancestors(tree, out.world_frame, source);
  const auto lca = std::find_first_of(up_ins.begin(), up_ins.end(), up_world.begin(), up_world.end());
  if (lca == up_ins.end()) {
    throw InputError(source, "", fmt::format("TF: no chain of transforms joins '{}' and '{}'. Transforms: {}",
                                             out.world_frame, out.ins_frame, describe_tree(tree)));
  }
  const std::size_t n_ins = static_cast<std::size_t>(lca - up_ins.begin());
  const std::size_t n_world = static_cast<std::size_t>(std::find(up_world.begin(), up_world.end(), *lca) - up_world.begin());

  // Time base: the moving link of the path with the most stamps.
  const Edge* base = nullptr;
  std::string chain = out.world_frame;  // "world <- common frame -> ... -> ins"
  for (std::size_t k = 0; k < n_world; ++k) chain += " <- " + up_world[k + 1];
  for (std::size_t k = n_ins; k-- > 0;) {
    const Edge& e = tree.at(up_ins[k]);
    chain += " -> " + up_ins[k] + (e.moving ? "" : " (static)");
    if (e.moving && (base == nullptr || e.samples.size() > base->samples.size())) base = &e;
  }
  for (std::size_t k = 0; k < n_world; ++k) {
    const Edge& e = tree.at(up_world[k]);
    if (e.moving && (base == nullptr || e.samples.size() > base->samples.size())) base = &e;
  }
  out.chain = chain;
  if (base == nullptr) {
    throw InputError(source, "", fmt::format("TF: the chain {} holds only static transforms: it does not move", chain));
  }
  for (const auto& [t_s, unused] : base->samples) {
    const auto T_lca_ins = compose_up(tree, up_ins, n_ins, t_s), T_lca_world = compose_up(tree, up_world, n_world, t_s);
    if (!T_lca_ins || !T_lca_world) {
      ++out.samples_outside;
      continue;
    }
    const Iso3 T_world_ins = T_lca_world->inverse() * *T_lca_ins;
    InsRecord r;
    r.t_s = t_s;
    r.p_world_m = T_world_ins.translation();
    r.R_world_ins = T_world_ins.linear();
    out.records.push_back(r);
  }
  return out;
}

}  // namespace insalign::io
