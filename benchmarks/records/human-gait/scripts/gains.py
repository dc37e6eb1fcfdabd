"""Print each actuator's kp, kv, force cap, joint damping/armature, range, and a few body numbers."""
import sys
import numpy as np, mujoco
from sim2real.robot import load_robot
from sim2real.simulation.model.builder import build_model
for name in sys.argv[1:]:
    r = load_robot(name)
    m = build_model(r)
    M = float(sum(m.body_mass)); g = 9.81; L = r.leg_length
    print(f"== {name}: mass {M:.2f} kg, leg {L:.3f} m, mgL {M*g*L:.1f} N m, tick {getattr(r,'control_tick_s',None)}")
    b = r.body
    f = b.foot
    print(f"   foot L x W {f.length:.3f} x {f.width:.3f} m (/leg {f.length/L:.2f} x {f.width/L:.3f}), heel {f.heel:.3f}, hip spacing {b.hip_spacing:.3f} (/leg {b.hip_spacing/L:.3f}), sole half-width - half hip spacing {(f.width-b.hip_spacing)/2*1000:.0f} mm")
    for i in range(m.nu):
        j = m.actuator_trnid[i, 0]
        kp = m.actuator_gainprm[i, 0]; kv = -m.actuator_biasprm[i, 2]
        cap = m.actuator_forcerange[i, 1]
        jn = m.joint(j).name
        lo, hi = np.degrees(m.jnt_range[j])
        dof = m.jnt_dofadr[j]
        e_sat = np.degrees(cap / kp) if kp > 0 else float('nan')
        print(f"   {jn:18s} range [{lo:6.1f},{hi:6.1f}] kp {kp:10.1f} N m/rad  kv {kv:8.2f}  cap {cap:7.2f} N m ({cap/M:.2f} N m/kg, {cap/(M*g*L):.2f} mgL)  sat at {e_sat:6.2f} deg  damping {m.dof_damping[dof]:.3f} armature {m.dof_armature[dof]:.4f}")
