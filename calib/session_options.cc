#include "calib/session_options.h"

namespace omni::calib {

CalibrationOptions OptionsFromSession(const io::Session& session) {
  CalibrationOptions options;
  options.estimate = session.estimate;
  options.priors = session.priors;
  options.solver = session.solver;
  options.use_lips = session.use_lips;
  if (session.consider) options.considered_sigma = *session.consider;
  if (!session.profile.empty()) options.profile = session.profile;
  if (!session.noncentral.empty()) options.noncentral = session.noncentral;
  if (session.profile_sigma_mm > 0) options.profile_sigma_mm = session.profile_sigma_mm;
  return options;
}

}  // namespace omni::calib
