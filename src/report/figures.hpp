// Figures of the reports that tests check alone.
#pragma once

#include "hapticcal/identification/identification.hpp"
#include "hapticcal/report/report.hpp"

namespace hapticcal::detail {

// calibrate's correlation map of the identified parameters, rows and columns
// in the order of the report's parameter table (KinematicFit::parameters).
FigureSpec correlation_figure(const KinematicFit& fit);

}  // namespace hapticcal::detail
