// Structure, attribute and plausibility checks of a URDF (see urdf_checks.hpp).

#include "model/urdf_checks.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "isowrench/error.hpp"
#include "isowrench/input_checks.hpp"
#include "util/text.hpp"

namespace isowrench::urdf_checks {
namespace {

constexpr const char* kTagPrefix = "isowrench:";

std::string Line(const std::string& source, const tinyxml2::XMLElement& e) {
  return source + ":" + std::to_string(e.GetLineNum());
}

std::string LinkOf(const tinyxml2::XMLElement& joint, const char* child) {
  const tinyxml2::XMLElement* e = joint.FirstChildElement(child);
  const char* link = e ? e->Attribute("link") : nullptr;
  return link ? link : "";
}

struct JointInfo {
  std::string name;
  std::string parent;
  std::string child;
  const tinyxml2::XMLElement* element;
};

}  // namespace

void CheckJointTree(const tinyxml2::XMLElement& robot, const std::string& source) {
  std::vector<JointInfo> joints;
  for (auto* e = robot.FirstChildElement("joint"); e; e = e->NextSiblingElement("joint")) {
    const char* name = e->Attribute("name");
    joints.push_back({name ? name : "", LinkOf(*e, "parent"), LinkOf(*e, "child"), e});
  }
  // child link -> the joint whose child it is
  std::map<std::string, size_t> parent_joint;
  for (size_t i = 0; i < joints.size(); ++i) {
    const JointInfo& j = joints[i];
    if (j.parent.empty() || j.child.empty()) continue;  // urdfdom reports the missing element
    if (j.parent == j.child) {
      throw Error(Line(source, *j.element) + ": joint '" + j.name + "' has link '" + j.parent +
                  "' as both parent and child; a joint connects two different links");
    }
    auto [it, inserted] = parent_joint.emplace(j.child, i);
    if (!inserted) {
      const JointInfo& first = joints[it->second];
      throw Error(Line(source, *j.element) + ": link '" + j.child +
                  "' has two parents: it is the child of joint '" + first.name + "' (line " +
                  std::to_string(first.element->GetLineNum()) + ") and of joint '" + j.name +
                  "'; URDF joints must form a tree");
    }
  }
  // Each link has at most one parent joint, so following parents from any link either ends at
  // a root or enters a loop. Colour links: 0 unvisited, 1 on the current walk, 2 done.
  std::map<std::string, int> state;
  for (const auto& start : parent_joint) {
    if (state[start.first] != 0) continue;
    std::vector<std::string> walk;
    std::string link = start.first;
    while (true) {
      int& s = state[link];
      if (s == 2) break;
      if (s == 1) {
        // loop: the links from `link`'s first appearance in `walk` to the end
        auto first = std::find(walk.begin(), walk.end(), link);
        std::vector<std::string> names;
        const tinyxml2::XMLElement* element = nullptr;
        for (auto l = first; l != walk.end(); ++l) {
          const JointInfo& j = joints[parent_joint.at(*l)];
          names.push_back("'" + j.name + "' (" + j.parent + " -> " + j.child + ")");
          if (!element || j.element->GetLineNum() < element->GetLineNum()) element = j.element;
        }
        throw Error(Line(source, *element) + ": joints " + util::Join(names, ", ") +
                    " form a loop; URDF joints must form a tree from one root link");
      }
      s = 1;
      walk.push_back(link);
      auto p = parent_joint.find(link);
      if (p == parent_joint.end()) break;
      link = joints[p->second].parent;
    }
    for (const std::string& l : walk) state[l] = 2;
  }
}

const std::vector<std::string>& AllowedAttributes(const std::string& local_name) {
  // One table per element. Function elements and coordinate/coupling/moving elements follow
  // the shared contract in docs/urdf-extensions.md.
  static const std::map<std::string, std::vector<std::string>> kTables = {
      {"joint", {"name", "role", "stiffness", "locked"}},
      {"transducer", {"link", "xyz", "rpy", "axes", "stiffness", "preset", "released"}},
      {"muscle",
       {"name", "max_force", "model", "optimal_fiber_length", "tendon_slack_length",
        "pennation_angle_at_optimal", "maximum_pennation_angle", "minimum_activation",
        "ignore_tendon_compliance", "fiber_damping"}},
      {"active_force_length",
       {"min_norm_active_fiber_length", "transition_norm_fiber_length",
        "max_norm_active_fiber_length", "shallow_ascending_slope", "minimum_value"}},
      {"fiber_force_length",
       {"strain_at_zero_force", "strain_at_one_norm_force", "stiffness_at_low_force",
        "stiffness_at_one_norm_force", "curviness"}},
      {"tendon_force_length",
       {"strain_at_one_norm_force", "stiffness_at_one_norm_force", "norm_force_at_toe_end",
        "curviness"}},
      {"thelen2003_curves",
       {"FmaxTendonStrain", "FmaxMuscleStrain", "KshapeActive", "KshapePassive"}},
      {"point", {"link", "xyz", "active_coordinate", "active_range"}},
      {"wrap",
       {"name", "link", "shape", "radius", "length", "radii", "inner_radius", "outer_radius",
        "translation", "xyz_body_rotation", "active", "quadrant"}},
      {"path_wrap", {"object", "range", "method"}},
      {"posture", {"joint", "degrees", "value"}},
      {"coordinate", {"name", "type", "default", "lower", "upper", "locked"}},
      {"coupling", {"joint", "coordinate"}},
      {"moving", {"axis", "coordinate"}},
      {"constant", {"value"}},
      {"linear", {"slope", "intercept"}},
      {"simm_spline", {"x", "y"}},
      {"natural_cubic_spline", {"x", "y"}},
      {"piecewise_linear", {"x", "y"}},
      {"polynomial", {"coefficients"}},
      {"multiplier", {"scale"}},
  };
  static const std::vector<std::string> kNone;
  auto it = kTables.find(local_name);
  return it == kTables.end() ? kNone : it->second;
}

namespace {

/// Where an isowrench element may stand: the local names of its allowed parents ("robot" for
/// the top level). Elements not listed here (functions, and any new element) may stand anywhere
/// their parent's reader accepts them.
const std::map<std::string, std::vector<std::string>>& Placement() {
  static const std::map<std::string, std::vector<std::string>> kPlacement = {
      {"joint", {"robot"}},
      {"transducer", {"robot"}},
      {"muscle", {"robot"}},
      {"posture", {"robot"}},
      {"coordinate", {"robot"}},
      {"coupling", {"robot"}},
      {"point", {"isowrench:muscle"}},
      {"moving", {"isowrench:point"}},
      {"wrap", {"robot"}},
      {"path_wrap", {"isowrench:muscle"}},
  };
  return kPlacement;
}

/// Top-level isowrench elements declared at most once per value of their key attribute ("" for
/// an element declared at most once at all).
const std::map<std::string, std::string>& UniqueKeys() {
  static const std::map<std::string, std::string> kUnique = {
      {"joint", "name"},      {"transducer", ""},    {"muscle", "name"}, {"posture", "joint"},
      {"coordinate", "name"}, {"coupling", "joint"}, {"wrap", "name"},
  };
  return kUnique;
}

/// The xmlns declaration in scope for `prefix` ("" = the default namespace) at `e`, or null.
const tinyxml2::XMLAttribute* NamespaceDeclaration(const tinyxml2::XMLElement& e,
                                                   const std::string& prefix) {
  const std::string name = prefix.empty() ? "xmlns" : "xmlns:" + prefix;
  for (const tinyxml2::XMLNode* n = &e; n; n = n->Parent()) {
    const tinyxml2::XMLElement* element = n->ToElement();
    if (!element) continue;
    for (const tinyxml2::XMLAttribute* a = element->FirstAttribute(); a; a = a->Next()) {
      if (name == a->Name()) return a;
    }
  }
  return nullptr;
}

/// The element carrying `declaration` at or above `e` (for its line number).
const tinyxml2::XMLElement* Declarer(const tinyxml2::XMLElement& e,
                                     const tinyxml2::XMLAttribute* declaration) {
  for (const tinyxml2::XMLNode* n = &e; n; n = n->Parent()) {
    const tinyxml2::XMLElement* element = n->ToElement();
    if (!element) continue;
    for (const tinyxml2::XMLAttribute* a = element->FirstAttribute(); a; a = a->Next()) {
      if (a == declaration) return element;
    }
  }
  return &e;
}

void CheckNamespace(const tinyxml2::XMLElement& e, const std::string& source) {
  const std::string tag = e.Name();
  const size_t colon = tag.find(':');
  const std::string prefix = colon == std::string::npos ? "" : tag.substr(0, colon);
  const std::string local = colon == std::string::npos ? tag : tag.substr(colon + 1);
  if (prefix == "isowrench") return;
  const tinyxml2::XMLAttribute* declaration = NamespaceDeclaration(e, prefix);
  if (declaration && std::string(declaration->Value()) == kNamespaceUri) {
    const tinyxml2::XMLElement* declarer = Declarer(e, declaration);
    throw Error(
        Line(source, e) + ": <" + tag + "> is in isowrench's namespace through " +
        (prefix.empty() ? std::string("the default namespace") : "the prefix '" + prefix + "'") +
        " (" + declaration->Name() + "=\"" + kNamespaceUri + "\" at line " +
        std::to_string(declarer->GetLineNum()) +
        "), but isowrench reads its elements only under the prefix isowrench:; write <" +
        kTagPrefix + local + ">");
  }
  if (!prefix.empty() && !declaration && prefix != "xml") {
    const bool ours = !AllowedAttributes(local).empty();
    throw Error(
        Line(source, e) + ": <" + tag + ">: the namespace prefix '" + prefix +
        "' is declared nowhere (no xmlns:" + prefix + "=\"...\" on this element or above)" +
        (ours ? "; isowrench's elements are written <" + std::string(kTagPrefix) + local + ">"
              : std::string()));
  }
}

}  // namespace

void CheckDeclarations(const tinyxml2::XMLElement& robot, const std::string& source) {
  // Namespaces and placement: iterative depth-first walk (input depth is unbounded).
  std::vector<const tinyxml2::XMLElement*> stack{&robot};
  while (!stack.empty()) {
    const tinyxml2::XMLElement* e = stack.back();
    stack.pop_back();
    for (auto* c = e->LastChildElement(); c; c = c->PreviousSiblingElement()) stack.push_back(c);
    CheckNamespace(*e, source);
    const std::string tag = e->Name();
    if (tag.rfind(kTagPrefix, 0) != 0) continue;
    auto place = Placement().find(tag.substr(std::string(kTagPrefix).size()));
    if (place == Placement().end()) continue;
    const tinyxml2::XMLElement* parent = e->Parent() ? e->Parent()->ToElement() : nullptr;
    const std::string parent_tag = parent ? parent->Name() : "";
    const std::vector<std::string>& allowed = place->second;
    if (std::find(allowed.begin(), allowed.end(), parent_tag) != allowed.end()) continue;
    // Directly in <robot> or in an isowrench element, the parent's reader names what it expects;
    // inside a standard element (a <link>, a <joint>, <gazebo>) nothing would read it.
    if (parent_tag == "robot" || parent_tag.rfind(kTagPrefix, 0) == 0) continue;
    std::vector<std::string> shown;
    for (const std::string& a : allowed) shown.push_back("<" + a + ">");
    throw Error(Line(source, *e) + ": <" + tag + "> stands inside <" + parent_tag + "> (line " +
                std::to_string(parent ? parent->GetLineNum() : 0) +
                "), where isowrench does not read it; it belongs directly inside " +
                util::Join(shown, " or "));
  }
  // The same declaration twice.
  std::map<std::string, const tinyxml2::XMLElement*> seen;  // "local\nkey" -> first element
  for (auto* e = robot.FirstChildElement(); e; e = e->NextSiblingElement()) {
    const std::string tag = e->Name();
    if (tag.rfind(kTagPrefix, 0) != 0) continue;
    const std::string local = tag.substr(std::string(kTagPrefix).size());
    auto unique = UniqueKeys().find(local);
    if (unique == UniqueKeys().end()) continue;
    const char* key = unique->second.empty() ? "" : e->Attribute(unique->second.c_str());
    if (!key) continue;  // the element's reader reports the missing attribute
    auto [it, inserted] = seen.emplace(local + "\n" + key, e);
    if (inserted) continue;
    const std::string what = unique->second.empty()
                                 ? "a second <" + tag + ">; a limb has one"
                                 : "<" + tag + "> '" + key + "' is declared twice";
    throw Error(Line(source, *e) + ": " + what + " (first at line " +
                std::to_string(it->second->GetLineNum()) +
                "); isowrench would not know which to use: keep one" +
                (local == "joint" ? " (one element may carry role=, stiffness= and locked=)"
                                  : std::string()));
  }
}

void CheckExtensionAttributes(const tinyxml2::XMLElement& robot, const std::string& source) {
  // Iterative depth-first walk (no recursion: input depth is unbounded).
  std::vector<const tinyxml2::XMLElement*> stack;
  for (auto* e = robot.FirstChildElement(); e; e = e->NextSiblingElement()) stack.push_back(e);
  while (!stack.empty()) {
    const tinyxml2::XMLElement* e = stack.back();
    stack.pop_back();
    for (auto* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) stack.push_back(c);
    std::string tag = e->Name();
    if (tag.rfind(kTagPrefix, 0) != 0) continue;
    const std::vector<std::string>& allowed =
        AllowedAttributes(tag.substr(std::string(kTagPrefix).size()));
    if (allowed.empty()) continue;
    for (const tinyxml2::XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
      std::string name = a->Name();
      if (std::find(allowed.begin(), allowed.end(), name) != allowed.end()) continue;
      if (name.rfind("xmlns", 0) == 0) continue;
      throw Error(Line(source, *e) + ": <" + tag + "> has no attribute '" + name + "'" +
                  DidYouMean(name, allowed) + "; its attributes are " + util::Join(allowed, ", "));
    }
  }
}

}  // namespace isowrench::urdf_checks
