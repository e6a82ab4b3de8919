"""Physical constants of the simulated apparatus, each with where it comes from.

Sources are of these kinds, marked in the comment:

- ``thesis X.Y``  a statement in Eberman (1995), section X.Y;
- ``datasheet`` / ``datasheet-level``  a value of the PHANToM 1.0 (SensAble
  Technologies) or of a generic 1990s strain-gauge acquisition chain, or the
  range such parts have (the comment gives the range);
- ``physics``     a physical argument (handbook material value, geometry);
- ``identified``  system identification from a *signal* fact the thesis
  measured on its apparatus (a level, a frequency, which states its signals
  tell apart; the fact is named and checked by ``contactlab reproduce
  apparatus``);
- ``numerics``    a choice of the simulation itself (a seed, a step size).

Nothing here is tuned to reproduce an accuracy, confusion or error rate the
thesis reports.  Units are SI (m, kg, s, N) throughout.
"""

from __future__ import annotations

import math

# --------------------------------------------------------------------------
# World
# --------------------------------------------------------------------------
GRAVITY = 9.81
"""physics: standard gravity, m/s^2, acting along -z."""

# --------------------------------------------------------------------------
# PHANToM (the 3-DOF Cartesian robot of 3.4, 9.1)
# --------------------------------------------------------------------------
ROBOT_MASS = 0.075
"""datasheet: PHANToM 1.0 apparent mass at the tip "< 75 g" (kg), isotropic."""

SERVO_RATE_HZ = 1000.0
"""datasheet: PHANToM servo loop runs at 1 kHz; the controller output is held
between servo ticks (zero-order hold)."""

PHANTOM_CONTINUOUS_FORCE = 1.4
"""datasheet: PHANToM 1.0 continuous exertable force, N."""

PHANTOM_MAX_FORCE = 8.5
"""datasheet: PHANToM 1.0 peak exertable force, N."""

PHANTOM_MAX_STIFFNESS = 3500.0
"""datasheet: PHANToM 1.0 closed-loop stiffness, 3.5 N/mm; controller gains
are chosen as fractions of this."""

ROBOT_BACKDRIVE_FRICTION = 0.04
"""datasheet: Coulomb (dry) friction felt at the PHANToM's tip when it is backdriven,
N, isotropic.  SensAble's spec sheets for the PHANToM 1.0 / 1.5 (Premium) list a
"backdrive friction" of about 0.04 N (we quote this from memory of those sheets,
not from a document we could check here; the thesis gives no value.  Trust it to
within a factor of ~2).  A physical cross-check of the order of magnitude: a
20 W-class brushed DC motor (Maxon RE 25 class, as on the PHANToM) takes a
no-load current of a few tens of mA, i.e. a friction torque of roughly 0.5 mN m
(brushes + ball bearings), which the ~11:1 capstan and ~0.14 m link multiply by
~80 /m into ~0.04 N at the tip.  It is the friction of brushes, bearings and
capstan cable of all three motors; modelled as one isotropic Coulomb force on the
robot mass with a true stick state (dynamics module docstring).  Static and kinetic
values are taken equal: the sheets give one number."""

ROBOT_BACKDRIVE_STATIC_FRICTION = ROBOT_BACKDRIVE_FRICTION
"""datasheet: the breakaway (static) value of ROBOT_BACKDRIVE_FRICTION, N.  Brushes, preloaded
bearings and capstan cables stick somewhat harder than they slide, but the sheets give one
number, so static = kinetic by default; ``[apparatus] robot_static_friction_n`` sets a gap.
Measured: at 0.06 N (1.5x) the encoder-feedback integral force controller hunts between
breakaways (contact-force std 13 mN on a 0.2 N command, 5 mN without the gap), and the
start-of-motion burst of 7.2 does not need it (the command's velocity step makes it)."""

ROBOT_PRESLIDING_DISPLACEMENT = 12e-6
"""physics: displacement at the PHANToM's tip before its backdrive friction breaks away, m.
Dry friction is not a rigid lock below breakaway: junctions deform elastically first
(pre-sliding displacement; Dahl 1968, Armstrong-Helouvry et al. 1994, the bristles of the
LuGre model), a few micrometres in metal and graphite-on-copper contacts.  The PHANToM's
friction sits at the motors (brushes on a 3.5 mm commutator track, preloaded bearings):
3-5 um there is ~1 mrad of shaft rotation, 1 mrad / MOTOR_RAD_PER_TIP_M = 12 um at the tip.
So the stuck drive is a spring of ROBOT_BACKDRIVE_STATIC_FRICTION / 12 um (~3.3 N/mm) to
ground, not a rigid support: the motors' force noise (CONTROL_ERROR_STD) and commutation
ripple move the robot by fractions of a micrometre.  In free space that moves robot and
shell together (the sensor feels only the shell's inertia); pressed against an object the
sensor is the stiffest path to ground and carries most of that force noise, which is why a
pressed, still finger is louder than a free one (7.3.3's "extra vibration sensed when the
robot is touching an object", the apparatus experiment's pressed-louder fact)."""

PRESLIDING_DAMPING_RATIO = 0.5
"""physics: damping of the pre-sliding deflection as a ratio of critical on the mass the friction
holds (the drive, Apparatus.drive_mass; the whole robot for a rigid drive),
the value of the LuGre model's reference parameter set (Canudas de Wit et al. 1995:
sigma_1 = sqrt(sigma_0) on a unit mass): micro-slip at the junctions' edges dissipates
(pre-sliding hysteresis)."""

BRUSH_FRICTION_VARIATION = 0.25
"""datasheet-level: relative rms fluctuation of the kinetic backdrive friction with the motor
shaft angle while the drive turns: brushes bouncing over the 11 commutator bars and riding
the commutator's roughness, strands of the capstan cable rolling on and off the drum.  Small
brushed motors' friction torque ripples by 20-30 % of its mean (their no-load current ripple);
0.25.  The pattern repeats every shaft revolution (a circular commutator), with wavelengths
on the commutator surface (radius BRUSH_TRACK_RADIUS) from BRUSH_WAVELENGTH_MIN to one bar
pitch: at 50 mm/s of tip travel, 14 mm/s of brush sliding, i.e. 7 Hz (bars) to 2.8 kHz."""

BRUSH_TRACK_RADIUS = 3.5e-3
"""datasheet-level: commutator radius of a 25 mm brushed motor (RE 25 class), m."""

BRUSH_WAVELENGTH_MIN = 5e-6
"""physics, identified (thesis 7.3.3, a signal fact): shortest wavelength along the commutator of
the brush friction's ripple, m.  A graphite brush touches a turned and worn copper commutator at a
few load-bearing spots (a-spots) of micrometres to ~10 um (electrical-contact theory; the surface's
roughness, Ra ~0.2-0.8 um, has its asperities at those spacings), and its friction fluctuates as
spots are born and die: wavelengths below the spot size average out, so the cutoff lies between
~1 and ~10 um.  Within that range it is identified from 7.3.3's "Moving is a sufficiently higher
level of vibration that it is never confused with the stationary vibration level": with the
ripple's rms fixed (BRUSH_FRICTION_VARIATION), the cutoff sets how much of it lies above ~100 Hz
of a slow move, where the sensor's strain difference sees it.  Measured by the apparatus
experiment (seeds 1-5, rigid robot, amplifier noise 0.1 mN): at 10 um the slow 7.3 x-moves
(12 mm/s in their first unit) sit 0.04-0.06 nats above the stationary floor and the H0/H1
normal-fit error is 0.024-0.059; at 5 um it is 0.0001-0.004 (0.0004-0.0075 at the default
AMPLIFIER_FORCE_NOISE; moving-vs-stationary).  The table over one revolution (:func:`dynamics.brush_ripple_table`) resolves it (16384
points on the 22 mm track, 1.3 um apart)."""

ROBOT_VISCOUS_DAMPING = 0.1
"""physics: viscous damping on the robot mass, N s/m, from the motors' back-EMF
through the amplifiers.  A motor shorted through its winding resistance damps with
k_t^2 / R; for a RE 25-class motor (k_t ~ 23 mN m/A, R ~ 2 ohm) that is ~2.6e-4
N m s, reflected to the tip by (80 /m)^2 as ~1.8 N s/m.  But the PHANToM's
amplifiers are current (torque) amplifiers -- the force command must be a motor
torque for the 100:1 force dynamic range of 3.4 -- and a current loop rejects the
back-EMF as a disturbance by its loop gain: with a few-kHz current-loop bandwidth,
below ~5 % of it remains at the few-hundred-Hz frequencies of interest, ~0.1 N s/m.
Bearing viscous friction is smaller still (~0.005 N s/m at the tip).  So this term
is tiny (0.04 % of critical at the ~250 Hz robot-on-sensor mode): the PHANToM's own
dissipation is dominated by ROBOT_BACKDRIVE_FRICTION."""

MOTOR_RAD_PER_TIP_M = 80.0
"""datasheet + physics: motor-shaft rotation per metre of tip travel, rad/m, per Cartesian
axis.  The PHANToM 1.0 drives each joint through a capstan cable reduction of about 11:1
on links of about 0.14 m (Massie & Salisbury 1994; quoted from memory, as in
ROBOT_BACKDRIVE_FRICTION), so 11 / 0.14 m ~ 80 rad/m.  Cross-check against
ENCODER_RESOLUTION: a 500-line (2000 counts/rev quadrature) motor encoder of the
HEDS-5540 class then resolves 2 pi / 2000 / 80 = 0.039 mm at the tip, the datasheet's
"> 1000 dpi" (0.025-0.03 mm) to within the accuracy of these figures.  The simulator
treats each Cartesian axis as driven by one motor through this ratio (the real linkage
mixes the three motors by its Jacobian, which is near-diagonal with entries of this
order at the workspace centre)."""

ROTOR_INERTIA = 1.2e-6
"""datasheet: inertia of one motor's rotating parts, kg m^2: the rotor of a Maxon RE 25-class
ironless motor, 10.5-10.8 g cm^2 in the maxon catalogue (quoted from memory, as in
COMMUTATOR_SEGMENTS), plus the capstan on its shaft and the encoder's code wheel, ~1 g cm^2."""

ROTOR_MASS = ROTOR_INERTIA * MOTOR_RAD_PER_TIP_M ** 2
"""physics: the rotors' inertia reflected to the tip through MOTOR_RAD_PER_TIP_M (J G^2 =
7.7 g per Cartesian axis).  It is part of ROBOT_MASS (the datasheet's apparent mass includes the
reflected rotor inertia), and it is the one part of the robot that the motors' torque, the brush
friction with its ripple, the commutation ripple and the encoders act on directly: with the
cables on (CABLE_STIFFNESS) the rest of the robot (capstan drums, links, gimbal, sensor body) is
pulled along through them."""

CABLE_STIFFNESS = 4.0e4
"""physics: stiffness of the capstan-cable transmission at the tip, N/m per axis (``[apparatus]
cable_stiffness_n_per_m``; dynamics module docstring, "The drive's structure").  A preloaded
capstan drive pulls the drum with both runs of a steel cable, 2 E A / L of a ~0.46 mm 7x7
stainless cable (metallic area ~0.1 mm^2, strand modulus ~130 GPa) over ~30 mm of free span:
~9e5 N/m along the cable.  A tip displacement x moves the cable by x r_c MOTOR_RAD_PER_TIP_M,
0.18 x on a ~2.25 mm capstan (cable centre on a 4 mm shaft), so the tip feels 9e5 x 0.18^2 ~
3e4 N/m; a 3-4 mm capstan or a shorter span gives up to ~9e4 N/m (wraps on the capstan and the
cable's own constructional stretch only lower it).  4e4 N/m: with ROTOR_MASS against the rest of
the robot a ~380 Hz mode, where cable-driven arms of this size have their first drive modes.
It matters for the sensor because the drive's vibration while its motors turn (brush and cable
friction ripple, the force DAC's steps) acts on the light rotors, whose resonance on the cables
passes it on to the arm several times amplified; a rigid transmission passes it to the sensor
only through the shell's inertia.

The default apparatus keeps the cables rigid (``Apparatus.cable_stiffness = 0``); ``[apparatus]
cable_stiffness_n_per_m = 40000`` turns them on.  Measured by the apparatus experiment with this
stiffness and ROTOR_MASS (seeds 1-5, the other constants at their defaults): moving separates from
stationary further than on the rigid robot (H0/H1 normal-fit error 0.000, moving +0.39-0.44 nats
above the floor, rigid +0.27-0.30), but the rotors' resonance passes the brush ripple's short
wavelengths (BRUSH_WAVELENGTH_MIN) to the arm so amplified that the drive's vibration masks the
textures while stroking (sample A's unit-mean normal-fit error 0.16-0.22, wood no louder than
polished aluminium) and a pressed finger rises to +0.10-0.13 nats; 22-23 of 25 facts hold.
Measured earlier with the cables as the simulator's default (amplifier noise 1 mN): a finger
resting on sanded aluminium louder than one sliding over it, the arm's ~240 Hz ringing on a
pressed sensor (damped only by the cables and the sensor: the drive's friction acts on the rotors)
outlasting the impact-interval cap, and the encoder-feedback integral force loop, its encoders on
the rotors behind the cables' compliance, hunting against walls and corners.  The arm's own
damping (joint bearings, cable hysteresis) would have to be known before the cables can be the
default."""

CABLE_DAMPING_RATIO = 0.03
"""physics: damping of the cable mode as a ratio of critical: stranded steel cables on capstans
dissipate by inter-strand friction, 2-5 % of critical (as LINK_DAMPING_RATIO); 3 %."""

LINK_LENGTH = 0.14
"""datasheet-level: length of the PHANToM 1.0's links, m (MOTOR_RAD_PER_TIP_M's ~0.14 m)."""

LINK_STIFFNESS = 2.2e4
"""physics: bending stiffness of the PHANToM's distal link at the tip, N/m per axis, for the
link mode (dynamics module docstring, "The drive's structure"; ``[apparatus] link_stiffness_n_per_m``).
The link is a thin-walled aluminium tube (E = 70 GPa) of LINK_LENGTH, a cantilever of tip
stiffness 3 E I / L^3: 2.2e4 N/m for a 10 mm tube with a 1 mm wall (I = 2.9e-10 m^4; a
12.7 mm tube would give 4.8e4 N/m; joints and cables in series only lower it).  With
LINK_TIP_MASS and the shell on the tip against the rest of the robot this is a ~180 Hz mode;
cable-driven arms of this size have their first structural modes at 100-300 Hz (Gil et al.
2010 identified two vibration modes on one axis of a PHANToM 1.0 from its frequency response).

The default apparatus keeps the link rigid (``Apparatus.link_stiffness = 0``), because a
lumped tip cannot be what the sensor's base is at both frequencies the thesis measured.
Measured by the apparatus experiment with this stiffness and LINK_TIP_MASS (its page measures
every fact both ways; seeds 1-5, with the earlier 1 mN AMPLIFIER_FORCE_NOISE and 10 um
BRUSH_WAVELENGTH_MIN; with the present ones 19-22 of 25 hold, pressed only +0.006-0.010 nats above
stationary, post-impact ringing 544-582 Hz, sample A's error 0.18-0.22): the drive's brush ripple reaches the sensor through the mode,
moving separates from stationary (7.3.3; H0/H1 normal-fit error 0.0015-0.011) and pressed falls
between them (the link filters the amplifiers' noise on its way to a pressed sensor; H2 - H0
+0.02-0.04 nats, H0/H2 the largest confusion) -- but the sensor then rings on a 15 g base: 890
Hz in flight, its in-contact mode at ~600 Hz dominates after impacts (580-650 Hz), the impacts'
bounce trains settle sooner (median impact 0.087-0.10 s), an impact rings the 180 Hz link mode
so hard that it is the ringing the impact-spectrogram experiment fits (176 Hz on seed 0), where
3.3 and fig 7.1 show the shell's ~690 Hz, and the polished half of sample A, stroked at 9 mm/s
where the brush ripple lies below 250 Hz, carries the drive's vibration at the mode (sample A's
unit-mean normal-fit error 0.21-0.30). A base heavy enough for 3.3's ringing (>= 32 g for <=
800 Hz in flight, as on the rigid robot's 75 g) makes the pressed tip ring on the sensor at
~380 Hz, louder than a moving drive (at 35 g: post-impact ringing 772-789 Hz on seeds 1-3; on
seed 2 H2 - H0 +0.15 nats, H1/H2 error 0.43). The real link is a distributed beam, heavy at the sensor's
frequencies and resonant at a few hundred Hz; one lumped mass is either one or the other."""

LINK_TIP_MASS = 0.015
"""physics: the mass that rings on LINK_STIFFNESS at the tip, kg (the shell rides on it as
well): the sensor's body and its mount on the gimbal, ~12 g of aluminium and steel for a
fingertip-sized six-axis sensor, plus the modal mass of the cantilevered tube, 0.24 x its
~11 g."""

LINK_DAMPING_RATIO = 0.03
"""physics: damping of the link mode as a ratio of critical: bolted aluminium links on
capstan drives are lightly damped, 2-5 % (joint bearings, strand friction of the cables);
3 %."""

COMMUTATOR_SEGMENTS = 11
"""datasheet: number of commutator segments of the PHANToM's brushed motors, Maxon RE 25
class (20 W, graphite brushes; the maxon catalogue lists "Number of commutator segments"
per motor, 11 for the RE 25 -- quoted from memory of the catalogue, not from a document
we could check here; the RE series ranges from 7 to 13).  Sets the frequency and the
depth of the commutation torque ripple (COMMUTATION_RIPPLE_PP)."""

COMMUTATION_EVENTS_PER_REV = (2 * COMMUTATOR_SEGMENTS if COMMUTATOR_SEGMENTS % 2
                              else COMMUTATOR_SEGMENTS)
"""physics: commutation events per shaft revolution.  With an odd number K of segments and
two brushes the two brushes commutate alternately, 2K events per revolution; with an even
K they commutate together, K events.  The ripple frequency is this times the shaft speed
in rev/s (22 x 1.27 rev/s = 28 Hz at 0.1 m/s tip speed)."""

COMMUTATION_RIPPLE_PP = 1.0 - math.cos(math.pi / COMMUTATION_EVENTS_PER_REV)
"""physics: peak-to-peak commutation torque ripple of a brushed, ironless (no cogging)
motor under current control, as a fraction of its torque.  Between two commutation
events the armature current pattern is fixed on the rotor, so its magnetic axis turns
with the rotor through 2 pi / n_events; the torque goes as the cosine of its angle to
the ideal (quadrature) axis, which the brushes hold within +-pi / n_events.  So
k(theta) = cos(phi) with phi sawtoothing over [-pi/n, pi/n): a cusped waveform between
cos(pi/n) and 1, 1 - cos(pi/22) = 1.0 % peak-to-peak for 11 segments.  (The current
amplifier holds the current constant, so there is no extra current ripple from the
back-EMF; brush-bridging of a coil during commutation is neglected.)"""

FORCE_DYNAMIC_RANGE = 100.0
"""thesis 3.4: "high force dynamic range (around 100:1)"."""

FORCE_RESOLUTION = PHANTOM_CONTINUOUS_FORCE / FORCE_DYNAMIC_RANGE
"""thesis 3.4 + datasheet: the smallest force step the PHANToM resolves, its
continuous force over the 100:1 dynamic range (= 14 mN)."""

CONTROL_ERROR_STD = FORCE_RESOLUTION / math.sqrt(12.0)
"""thesis 3.4 + physics: the spread of the force DAC's error, N per axis.  An actuator that
resolves force in steps of FORCE_RESOLUTION makes an error spread uniformly over one step,
whose standard deviation is step / sqrt(12) (= 4.0 mN).  The simulator applies the step
itself (the servo's force command is rounded to FORCE_RESOLUTION at every tick,
``Apparatus.force_resolution``): while the command changes by more than a step between ticks
(moving, a force loop integrating) the error behaves as a random control wrench w of (4.12)
of this size; while it is constant (the robot at rest, its encoders still) the error is a
constant force, and only AMPLIFIER_FORCE_NOISE stays random."""

AMPLIFIER_FORCE_NOISE = 2.0e-4
"""datasheet-level, identified (thesis 7.3.3, 9.1.3, signal facts): random force at the tip from
the motors' current amplifiers, N rms per axis, one independent draw per servo tick (the random
part of the control wrench w of 4.12).  Its mechanisms bound it.  The current loop's own noise
(sense-resistor and op-amp noise, ~10 nV/sqrt(Hz) over a few-kHz loop bandwidth) is a few uA; the
command from the servo computer's DAC board adds its analogue output noise (0.1-1 mV rms over the
amplifier's bandwidth for the 12-bit boards of the period) times the amplifier's transconductance
(a few tenths of A/V): 30-300 uA.  With a torque constant of ~23 mN m/A (RE 25 class) and
MOTOR_RAD_PER_TIP_M = 80 /m, 1 uA is 1.8 uN at the tip, so 5 uN to 0.5 mN.  Within that range the
value is identified from what the thesis says of the signals: a pressed, still finger is louder
than a free, still one ("extra vibration sensed when the robot is touching an object", 7.3.3),
but only a little -- stationary and pressed are the two states its vibration tells apart worst,
moving is well above both; and the integral force controller slides without stick-slip (9.1.3),
which the noise helps by dithering the drive's stiction.  0.2 mN (~110 uA).  Measured by the
apparatus experiment (seeds 1-5): pressed 0.051-0.056 nats above stationary, its normal-fit
error against stationary the largest of the three by 0.10-0.16; stuck fraction of the force
controller on wood 0.020-0.053 (criterion 0.05; seeds 6-12 0.019-0.047).  At 0.1-0.15 mN the
pressed facts hold as well, at 0.25 mN an impact's ringing on seed 3 is labelled shorter than
0.1 s; at 1 mN (0.5 mA, an earlier value) a pressed finger is 0.3 nats above stationary on the
rigid robot and 0.6-0.7 nats with the capstan cables, louder than a moving one.  At every level
tried the encoder-feedback integral force loop, pushed along the normal of a maze wall's edge
(tests/test_sim_maze.py, x wall), falls on some seeds into a ~290 Hz limit cycle across one
encoder count, the robot on the pressed sensor fed by the derivative term's encoder steps: 3 of
seeds 1-12 at 0.2 mN, 6-7 at 0.15-0.175 mN, 7 at 0.25 mN, 6 at 1 mN (3 at 1 mN with the earlier
10 um BRUSH_WAVELENGTH_MIN).  It is what a still robot's motors shake it with (the DAC's error is then constant,
CONTROL_ERROR_STD), and through a pressed contact it reaches the sensor
(ROBOT_PRESLIDING_DISPLACEMENT)."""

ENCODER_RESOLUTION = 0.03e-3
"""datasheet: PHANToM 1.0 nominal position resolution "> 1000 dpi" = 0.03 mm,
applied per Cartesian axis to the robot-side position (encoders are on the
motors, thesis 1.2/7.2)."""

KINEMATIC_ANGLE_ERROR_DEG = 1.0
"""thesis 8.1.1.2: "It is very possible that the kinematic chain from the block, to the table,
to the PHANToM, and finally to the fingertip has 1-2 deg of angular error."  The linear part
of the PHANToM's position error: the reported position is (I + A) p with A's entries drawn
once (CALIBRATION_SEED) with this standard deviation (degrees as radians), so a direction
reads off by about sqrt(2) x 1 = 1.4 deg rms (rotation and skew of the position frame against
the force frame); KINEMATIC_CURVATURE adds about 1 deg more per cm from the workspace centre."""

KINEMATIC_CURVATURE = 1.9
"""identified (thesis 8.1.1.2, a signal fact): "There is enough kinematic error in the robot to
produce a 1 mm deviation from a straight-line fit to the x and y position data over a maximum
of 80 mm."  The nonlinear part of the position error, 0.5 Q(p, p) with Q's entries drawn once
with this standard deviation (1/m): a straight path of length L reads as a parabola whose
largest deviation from its straight-line fit is |Q(d, d)| L^2 / 12, 1 mm at 80 mm for
|Q| = 1.9 /m.  It stands for link-length and joint-offset errors of the real linkage, whose
position error varies smoothly (as sines of the joint angles) over the workspace."""

VELOCITY_LOWPASS_HZ = 20.0
"""physics: the thesis differences encoder positions and lowpasses them (1.2)
without giving the cutoff.  At 1 kHz a 0.03 mm step is a 30 mm/s velocity
step; a 2nd-order 20 Hz lowpass brings that to about the 1-10 mm/s scale of
the thesis's moving/fixed velocity models (9.1.1) while passing the few-Hz
motions of the tasks."""

SERVO_VELOCITY_LOWPASS_HZ = 100.0
"""physics: the servo loop's own velocity estimate (first difference of the
encoder position, 2nd-order Butterworth lowpass at the 1 kHz servo rate).  The
20 Hz filter of the recorded velocity cannot be used inside the loop: the
derivative path of a critically damped 200 N/m loop on the 85 g moving mass
crosses over near b/m ~ 100 rad/s = 16 Hz, where a 20 Hz filter lags ~70 deg and
the loop goes unstable.  A filter 5x above the stiffest loop's 15 Hz (800 N/m)
lags 13 deg there; the price is encoder-step noise passed up to 100 Hz."""

POSITION_DAMPING_RATIO = 0.2
"""physics: the PD position loop's derivative gain is limited by the velocity it
differentiates from 0.03 mm encoder steps (about 12 mm/s rms at 1 kHz): a gain of
~1 N s/m already injects motor-force noise the size of CONTROL_ERROR_STD.  On
the low-stiffness (100 N/m) controller of 9.1.2 and the 85 g moving mass that is
a damping ratio of about 0.2, a lightly damped loop."""

# --------------------------------------------------------------------------
# Fingertip sensor (Bicchi's 6-axis fingertip sensor, 3.3/3.4)
# --------------------------------------------------------------------------
SHELL_MODE_HZ = 690.0
"""thesis 3.3: "The shell has a lightly damped natural frequency of
approximately 690 Hz when the base is fixed and the shell free"."""

SHELL_DAMPING_RATIO = 0.02
"""physics: "lightly damped" (thesis 3.3); bolted metal structures have
modal damping ratios of 1-5 %, we take 2 %."""

FINGERTIP_RADIUS = 0.010
"""physics: the sensor is "shaped like a fingertip" (thesis 1.2): a 20 mm
diameter hemispherical shell, the width of a human fingertip."""

SHELL_MASS = 0.010
"""physics: a 20 mm hemispherical metal shell 1-2 mm thick plus its fixing
ring, about 10 g.  This is the end-effector inertia H of (4.8)."""

SENSOR_STIFFNESS = SHELL_MASS * (2.0 * math.pi * SHELL_MODE_HZ) ** 2
"""derived: the sensor spring K of (4.6) is the one that, with the shell mass,
puts the fixed-base shell mode at SHELL_MODE_HZ (about 1.9e5 N/m)."""

SENSOR_DAMPING = 2.0 * SHELL_DAMPING_RATIO * math.sqrt(SENSOR_STIFFNESS * SHELL_MASS)
"""derived: the sensor damper B of (4.6) from SHELL_DAMPING_RATIO."""

SENSOR_ORIGIN_OFFSET = 0.010
"""physics: the Maltese cross (sensor origin, where torques are referred) sits
at the base of the shell, one radius above the sphere centre; the fingertip
points down (-z), as on the PHANToM in the thesis's figure 1.2."""

SENSOR_ARM_LENGTH = 0.006
"""physics: length of the Maltese-cross arms from the hub to the shell fixing,
a bit more than half the shell radius (thesis 3.3: cross with 8 half-bridges)."""

SHELL_YOUNGS_MODULUS = 200e9
"""physics: the shell is taken to be steel (handbook E = 200 GPa).  The thesis
does not say; steel and aluminium give contact stiffnesses within 2x."""

SHELL_POISSON_RATIO = 0.30
"""physics: handbook value for steel."""

TANGENTIAL_STIFFNESS_RATIO = 0.8
"""physics: Mindlin: tangential/normal contact stiffness = 2(1-nu)/(2-nu),
about 0.8 for nu near 0.3."""

# --------------------------------------------------------------------------
# Strain-gauge acquisition (7.1)
# --------------------------------------------------------------------------
OUTPUT_RATE_HZ = 1000.0
"""thesis 7.1: strains sampled at 1000 Hz."""

IMPACT_OUTPUT_RATE_HZ = 2700.0
"""thesis 7.1 (fig 7.1): the impact spectrogram was sampled at 2700 Hz."""

SENSOR_FORCE_RANGE = 10.0
"""physics: full-scale force, N; covers the PHANToM's 8.5 N peak force."""

SENSOR_TORQUE_RANGE = SENSOR_FORCE_RANGE * (FINGERTIP_RADIUS + SENSOR_ORIGIN_OFFSET)
"""physics: full-scale torque, N m: full-scale force at the farthest contact
point from the sensor origin (radius + offset)."""

ADC_BITS = 16
"""identified (thesis 7.3.3, a signal fact): "Moving is a sufficiently higher level of
vibration that it is never confused with the stationary vibration level".  The thesis never
names its converter.  With 12 bits (a 4.9 mV step, 14-47 mN of force per bridge) the drive's
vibration while moving and most texture vibration stay below one step, y_h of the stationary,
moving and pressed states all sit at the quantisation floor and moving *is* confused with
stationary (the apparatus experiment measures it: normal-fit error 0.25).  16-bit converters
(0.31 mV step) were period hardware on VME acquisition boards (Burr-Brown ADS7805 / Analog
Devices AD7884 class), and with them the amplifier noise below (2.5 steps) dithers the
converter, as a well-designed chain does.  ``[apparatus] adc_bits = 12`` in a spec simulates
the 12-bit board."""

ADC_RANGE_V = 10.0
"""datasheet: bipolar +/-10 V converter input."""

ADC_HEADROOM = 0.8
"""physics: amplifier gains set so that a worst-case full-scale wrench uses 80 % of the
converter range."""

BRIDGE_EXCITATION_V = 5.0
"""datasheet: bridge excitation, V.  5 V is the usual excitation of 350 ohm foil gauges on a
small aluminium or steel flexure (10 V is the usual maximum; self-heating of gauges on a
fingertip-sized cross argues for the lower value)."""

GAUGE_FACTOR = 2.0
"""datasheet: gauge factor of constantan foil strain gauges (2.0-2.1)."""

FULL_SCALE_STRAIN = 1.0e-3
"""physics: strain at the gauges under the full-scale wrench.  Metal-foil force sensors are
designed for 500-1500 microstrain at full scale (higher shortens fatigue life, lower wastes
signal); 1000 microstrain."""

BRIDGE_RESISTANCE = 350.0
"""datasheet: foil strain-gauge resistance, ohm (the standard 350 ohm)."""

AMPLIFIER_NOISE_DENSITY = 10.0e-9
"""datasheet: input voltage noise density of the bridge amplifier, V/sqrt(Hz).  Low-noise
instrumentation amplifiers of the period (Analog Devices AD524, PMI AMP01) give 5-10
nV/sqrt(Hz) at gains of 100-1000; 10 nV/sqrt(Hz) with the op-amp stages after them.  The
Johnson noise of the half-bridge (BRIDGE_RESISTANCE, 2.4 nV/sqrt(Hz) at 300 K) adds to it in
quadrature (StrainGaugeSensor.noise_v)."""

AMPLIFIER_BANDWIDTH_HZ = 1350.0
"""thesis 7.1 (fig 7.1): the amplifiers pass at least the 1350 Hz Nyquist band of the
2700 Hz impact record (its contour plot reaches 1350 Hz); a single-pole rolloff there has a
noise bandwidth of pi/2 times it.  Sampled at 1000 Hz the noise above 500 Hz aliases into
the band, so the sampled noise is white with the whole band's power."""

CALIBRATION_ERROR = 0.01
"""datasheet: error of the sensor's calibration matrix, per entry, as a fraction of the
largest entry of its column (so each wrench component reads with ~1 % gain error and
cross-talk).  Six-axis sensors are calibrated to 1-2 % of full scale
(ATI and JR3 sheets); the thesis computed its wrench from a calibration it did not check
(8.1.1.2 blames its angular errors partly on the chain from block to fingertip).  The true
strain pattern differs from the nominal matrix by these errors; the recorded wrench uses the
nominal inverse.  Drawn once from CALIBRATION_SEED: one physical sensor."""

CALIBRATION_SEED = 1995
"""numerics: seed of the one draw of the sensor's calibration error and of the PHANToM's
kinematic error (the same physical apparatus in every trial)."""

# --------------------------------------------------------------------------
# Simulation and ground-truth labelling
# --------------------------------------------------------------------------
INTERNAL_RATE_MIN_HZ = 20000.0
"""numerics: internal integration rate, at least 29x the 690 Hz mode (omega dt
= 0.22) and with the contact springs integrated linearly implicitly."""

MOVING_SPEED_THRESHOLD = 1.0e-3
"""labelling: fingertip speed above which the ground truth says "moving",
m/s; a tenth of the thesis's moving velocity model range (9.1.1: 0.01 m/s)."""

IMPACT_MIN_APPROACH_SPEED = 1.0e-3
"""labelling: a new contact made at a normal approach speed above this (m/s)
is labelled an impact."""

RING_LOWPASS_HZ = 30.0
"""labelling: the ringing envelope is the sensor force minus its 30 Hz
lowpass (motions of the tasks are below a few Hz, the shell mode is 690 Hz)."""

IMPACT_MAX_DURATION_S = 8.0 / (SHELL_DAMPING_RATIO * 2.0 * math.pi * SHELL_MODE_HZ)
"""labelling: the decay after the last event of an impact is cut after at most
8 decay time constants of the shell mode (an amplitude ratio of e^8 ~ 3000)
even if the ringing is still above the noise (a bounce train as a whole can be
longer; :func:`contactlab.sim.simulate._impact_intervals`)."""

ENVELOPE_CURVATURE_SIGMAS = 3.0
"""physics: the fingertip follows the longest-wavelength texture components as long as
their rms curvature stays below 1/(3 R): a Gaussian field's curvature exceeds 3 sigma
at ~0.1 % of points, so valleys tighter than the sphere are rare; the rest of the
roughness is bridged and acts through friction (materials module docstring)."""

TEXTURE_EDGE_MIN_WIDTH = 20e-6
"""physics: at the boundary between two textures (samples A and B) the fingertip
rests on both halves while its footprint straddles the split, and rolls over a
height step on an arc of its own radius rather than dropping off it.  The
followed heights are blended with a smoothstep over a width w; a step d then has
peak curvature 6 d / w^2, so w = sqrt(18 R d_max) keeps it at the 1/(3R) budget
of ENVELOPE_CURVATURE_SIGMAS, with d_max the largest possible step (the summed
followed amplitudes of both sides; ``Environment.pack``).  This floor, about a
Hertz contact radius, only keeps the width finite for untextured surfaces."""

IMPACT_QUIET_S = 0.003
"""labelling: the ringing counts as decayed once it has stayed below the sensor
noise for 3 ms, two periods of the slowest ringing mode (the ~250 Hz mode of the
robot mass on the sensor spring while the shell is held by a contact)."""

CONTACT_MARGIN = 1.0e-4
"""numerics: planes farther than radius + 0.1 mm from the fingertip centre are
not examined (textures are microns high)."""

LAY_ENVELOPE_STEP = 1.0e-6
"""numerics: grid step of the tabulated sphere envelope over a texture's lay (scratch)
components (materials module docstring), m.  The shortest texture wavelengths are
20-50 um and the Hertz patch (~30 um on aluminium) has already smoothed them, so a
1 um grid resolves every ridge top; linear interpolation between grid points changes
the envelope slope by at most step / R = 1e-4 per point, far below its ~0.01 rms."""

LAY_ENVELOPE_HALF_LENGTH = 0.1
"""numerics: the envelope table covers +-0.1 m along the lay direction from the plane's
origin, more than any simulated workspace (samples A/B span 51 mm, the maze +-45 mm);
beyond it the envelope is held at its end value."""

NOMINAL_NORMAL_LOAD = 0.2
"""thesis 7.2: the 200 mN downward force of the stroking experiment, N; the load at which
the Hertz contact patch (texture smoothing) and the load sharing between supporting
ridge crests (the lay envelope) are evaluated (materials module docstring)."""

LAY_RIDGE_MIN_ANISOTROPY = 0.5
"""physics: a texture's lay components are treated as straight ridges that the sphere
rides over (its exact 1-D envelope, materials module docstring) only when the lay
carries most of the relief, i.e. the highest points under the footprint lie on ridge
crests (crosswise 80-grit scratches, anisotropy 0.9).  Where most of the relief is
isotropic (rough wood, 0.3) the sphere is held by isolated 2-D peaks whose hand-overs
a 1-D ridge profile does not represent, and the spectral followed/bridged split is kept
for all components."""


BOLTZMANN = 1.380649e-23
"""physics: Boltzmann's constant, J/K (the bridge's Johnson noise)."""

ROOM_TEMPERATURE_K = 300.0
"""physics: the bridge's temperature, K (a laboratory at about 27 C)."""
