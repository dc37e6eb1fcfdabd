#!/bin/sh
# One human-gait ablation arm: 2 bodies x 3 seeds, 200 generations each, one thread a run.
# Resumable: run the same line again and finished runs are read back, cut ones continued.
#   sh benchmarks/records/human-gait/run_arm.sh ARM [OUT]      (from the project's root)
# ARM: baseline, clock, ankle0, speed, clock_speed, clock_speed_gait, clock_speed_gait16,
#      clock_speed_flight_stop, clock_speed_soft, clock_speed_smooth, clock_speed_ankle0, clock_compliant,
#      clock_compliant_straight, clock_compliant_straight_slow, clock_compliant_straight_slow_harness75,
#      clock_compliant_straight_slow_pace, clock_medium_gait, clock_medium_gait_gyro,
#      clock_medium_gait_flight_stop, clock_uniform_gait,
#      no_side_bias, no_sideways_harness, gait_term
set -eu
arm=${1:?"give an arm (see above)"}
out=${2:-runs/human-gait/$arm}
here=benchmarks/records/human-gait/configs
config=$here/base.yaml
robot=human_stepping
case $arm in
  baseline) ;;
  clock|no_side_bias|no_sideways_harness|gait_term) config=$here/$arm.yaml ;;
  ankle0) robot=$here/human_stepping_ankle0.yaml ;;
  speed) robot=$here/human_stepping_speed.yaml ;;
  clock_speed) config=$here/clock.yaml; robot=$here/human_stepping_speed.yaml ;;
  clock_speed_gait) config=$here/clock_gait_term.yaml; robot=$here/human_stepping_speed.yaml ;;
  clock_speed_gait16) config=$here/clock_gait_term16.yaml; robot=$here/human_stepping_speed.yaml ;;
  clock_speed_smooth) config=$here/clock_smooth.yaml; robot=$here/human_stepping_speed.yaml ;;
  clock_speed_ankle0) config=$here/clock.yaml; robot=$here/human_stepping_speed_ankle0.yaml ;;
  clock_compliant) config=$here/clock.yaml; robot=$here/human_stepping_compliant.yaml ;;
  clock_compliant_straight) config=$here/clock_straight.yaml; robot=$here/human_stepping_compliant.yaml ;;
  clock_compliant_straight_slow) config=$here/clock_straight_slow.yaml; robot=$here/human_stepping_compliant.yaml ;;
  clock_compliant_straight_slow_harness75)
    config=$here/clock_straight_slow_harness75.yaml; robot=$here/human_stepping_compliant.yaml ;;
  clock_compliant_straight_slow_pace)
    config=$here/clock_straight_slow_pace.yaml; robot=$here/human_stepping_compliant.yaml ;;
  clock_medium_gait) config=$here/clock_gait_term.yaml; robot=$here/human_stepping_medium.yaml ;;
  clock_medium_gait_gyro) config=$here/clock_gait_gyro.yaml; robot=$here/human_stepping_medium.yaml ;;
  clock_medium_gait_flight_stop)
    config=$here/clock_gait_flight_stop.yaml; robot=$here/human_stepping_medium.yaml ;;
  clock_uniform_gait) config=$here/clock_gait_term.yaml; robot=$here/human_stepping_uniform.yaml ;;
  clock_speed_soft) config=$here/clock.yaml; robot=$here/human_stepping_speed_soft.yaml ;;
  clock_speed_flight_stop) config=$here/clock_flight_stop.yaml; robot=$here/human_stepping_speed.yaml ;;
  *) echo "unknown arm: $arm" >&2; exit 2 ;;
esac
# PRESETS="male_50" runs one body only (two processes of one arm, one a core)
exec python -m benchmarks.human_walk --config "$config" --robot "$robot" --presets ${PRESETS:-female_50 male_50} \
  --seeds 1 2 3 --generations 200 --threads 1 --out "$out" --json
