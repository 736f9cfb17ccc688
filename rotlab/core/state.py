"""The state layout, named once: y = (Λ, ω, W), 8 components.

    y[LAMBDA] = y[0:4]  Λ, scalar-first unit quaternion, principal body frame → space
    y[OMEGA]  = y[4:7]  ω, principal body frame, rad/s
    y[WORK]   = y[7]    W = ∫ M_nc · ω dt, work of the non-conservative loads, J
"""

LAMBDA = slice(0, 4)
OMEGA = slice(4, 7)
WORK = 7
STATE_SIZE = 8
Q0, P0 = 0, 4  # first index of Λ and of ω (compiled code indexes components from these)
