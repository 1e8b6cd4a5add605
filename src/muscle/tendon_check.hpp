#pragma once
// The check that a muscle's tendon can be stretched at some posture (issue 28 item 7): called
// when a Model is built.

namespace isowrench {

class Model;

/// For every muscle with a force model and a tendon_slack_length > 0: the musculotendon path
/// must be longer than the tendon's slack length at some posture within the coordinates'
/// ranges, else the tendon is slack everywhere and the muscle can never pull. Cheap in the
/// usual case (one path length per muscle, at the nominal posture); a muscle slack there is
/// checked over kTendonCheckPostures postures (each coordinate at the ends and middle of its
/// range, then seeded random postures in the box; unbounded revolute coordinates over nominal
/// +- 180°, unbounded prismatic ones nominal +- 0.1 m).
/// Such a muscle gets a warning (Warn, input_checks.hpp) naming it, its tendon_slack_length and
/// the longest path found (mm), once per model name and muscle in a process (a fit rebuilding
/// the model per evaluation neither repeats the warning nor the search). A warning, not an
/// error: OpenSim accepts such a model (a muscle left at the class default tendon_slack_length
/// of 0.2 m) and gives that muscle 0 force.
void CheckTendonsCanStretch(const Model& model);

}  // namespace isowrench
