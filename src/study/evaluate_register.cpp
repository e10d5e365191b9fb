// evaluate --register: the model registered to the evaluated log first
// (register_for_evaluation, identification/registration.hpp), then scored.
#include <utility>

#include "hapticcal/identification/registration.hpp"
#include "hapticcal/study/evaluate.hpp"

namespace hapticcal {

Evaluation evaluate_registered(const DeviceModel& model, const Log& log, RegisterWhat what,
                               const std::vector<PointDistance>& point_distances,
                               const std::vector<KnownPoint>& known_points) {
  RegisteredModel r = register_for_evaluation(model, log, what);
  Evaluation ev = evaluate(r.model, log, point_distances, known_points);
  ev.registered = std::move(r.fit);
  return ev;
}

}  // namespace hapticcal
