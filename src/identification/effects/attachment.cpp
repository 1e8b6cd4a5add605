// Effect attachment:MUSCLE:POINT: one muscle path point displaced.

#include "identification/effect_type.hpp"
#include "isowrench/error.hpp"

namespace isowrench::ident {
namespace {

class Attachment final : public EffectType {
 public:
  EffectKindInfo Info() const override {
    return {"attachment",
            "attachment:MUSCLE:POINT (POINT = path point index, 0 = origin)",
            EffectStage::kModel,
            "Moves one path point of MUSCLE by a vector in its link's frame (a misplaced origin, "
            "insertion "
            "or via point).",
            "dx, dy, dz (mm, linear, -10 to 10)",
            "attachment of the neighbouring point of the same muscle; force_scale when the move is "
            "along the "
            "line of action"};
  }
  std::vector<Effect> Candidates(const Model& model,
                                 const std::vector<std::string>& muscles) const override {
    std::vector<Effect> out;
    for (const MuscleSpec& m : model.description().muscles) {
      if (!Wanted(muscles, m.name)) continue;
      for (size_t p = 0; p < m.path.size(); ++p) {
        Effect e;
        e.kind = "attachment";
        e.muscle = m.name;
        e.point = static_cast<int>(p);
        e.id = "attachment:" + m.name + ":" + std::to_string(p);
        e.description = "muscle " + m.name + " path point " + std::to_string(p) + " (on " +
                        m.path[p].link +
                        (p == 0                   ? ", origin"
                         : p + 1 == m.path.size() ? ", insertion"
                                                  : "") +
                        ") displaced, in the link's frame";
        for (const char* n : {"dx", "dy", "dz"})
          e.parameters.push_back(LinearParameter(n, "mm", 10.0));
        e.confounders = {"attachment:" + m.name + ":"};
        out.push_back(e);
      }
    }
    return out;
  }
  void Apply(const Effect& e, const std::vector<double>& v, AugmentedModel* m) const override {
    for (MuscleSpec& muscle : m->description.muscles) {
      if (muscle.name != e.muscle) continue;
      if (e.point < 0 || e.point >= static_cast<int>(muscle.path.size())) break;
      muscle.path[e.point].position += Eigen::Vector3d(v[0], v[1], v[2]) * kMillimetre;
      return;
    }
    throw Error("effect '" + e.id + "': muscle '" + e.muscle + "' has no path point " +
                std::to_string(e.point));
  }
};

}  // namespace

std::unique_ptr<EffectType> MakeEffect_attachment() { return std::make_unique<Attachment>(); }

}  // namespace isowrench::ident
