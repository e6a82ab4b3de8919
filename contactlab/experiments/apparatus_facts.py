"""What the thesis says about its apparatus's *signals*, and how each statement is checked.

Each :class:`Fact` quotes the thesis, names its section and states a criterion on one
number measured from simulated data (``low <= measured <= high``).  The criteria were
written down from the thesis's words before the simulator was calibrated against them,
and they are about signals (levels, frequencies, timings, which states are
distinguishable), never about the thesis's recognition accuracies or error rates.
:mod:`contactlab.experiments.apparatus` measures them (``contactlab reproduce apparatus``).

Signal conventions used by the measurements: y_h is the 7.1 log-energy of the strain
difference (block 8, 4:1, log floor at half a converter step), averaged over the 8 strain
channels, at 250 Hz; a "unit" is 100 consecutive y_h samples of one ground-truth state
(7.3: "segmented into units of 100 measurements"); the normal-fit error of two sets is the
equal-prior Bayes error of two normals fitted to them (fig 7.8's "normal fit").
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Fact:
    """One statement about the apparatus's signals and its criterion."""

    name: str
    section: str
    thesis: str
    measure: str
    unit: str
    low: float = -math.inf
    high: float = math.inf

    @property
    def criterion(self) -> str:
        if math.isinf(self.low):
            return f"{self.measure} <= {self.high:g} {self.unit}".rstrip()
        if math.isinf(self.high):
            return f"{self.measure} >= {self.low:g} {self.unit}".rstrip()
        return f"{self.low:g} <= {self.measure} <= {self.high:g} {self.unit}".rstrip()

    def holds(self, value: float) -> bool:
        return bool(math.isfinite(value) and self.low <= value <= self.high)


FACTS: tuple[Fact, ...] = (
    Fact("shell-mode", "3.3",
         "The shell has a lightly damped natural frequency of approximately 690 Hz when the "
         "base is fixed and the shell free.",
         "dominant frequency of the strain difference in the 0.1 s after an impact "
         "(2700 Hz record); the free base may raise it", "Hz", 600.0, 800.0),
    Fact("moving-vs-stationary", "7.3.3",
         "Moving is a sufficiently higher level of vibration that it is never confused with "
         "the stationary vibration level.",
         "normal-fit error between H1 (moving, free) and H0 (stationary, free) y_h units",
         "", -math.inf, 0.02),
    Fact("pressed-louder", "7.3.3",
         "these two models are being separated purely on extra vibration sensed when the "
         "robot is touching an object",
         "mean y_h of H2 (pressed, still) units minus that of H0 units", "nats", 0.02, math.inf),
    Fact("pressed-main-confusion", "7.3.3",
         "For both the training and the test data, the major confusion is between contact "
         "and stationary.",
         "normal-fit error H0/H2 minus the larger of H0/H1 and H1/H2", "", 1e-6, math.inf),
    Fact("sample-a-separates", "7.2.2, fig 7.8",
         "It is possible to achieve similar levels of success by testing just the magnitude "
         "of the vibration energy. (sample A: sanded vs polished aluminium)",
         "normal-fit error between the y_h of sanded and of polished aluminium while "
         "stroking sample A", "", -math.inf, 0.05),
    Fact("sample-b-wood-louder", "7.2.2",
         "Sample B: rough wood beside polished aluminium (rough surfaces vibrate more when "
         "stroked, 4.40).",
         "mean y_h over wood minus mean y_h over polished aluminium while stroking sample B",
         "nats", 0.1, math.inf),
    Fact("sample-b-harder", "7.2.2",
         "Sample B is harder to label than sample A (its expected error is the larger one).",
         "normal-fit error of sample B's two textures minus that of sample A's", "",
         1e-6, 0.45),
    Fact("start-burst", "7.2; 9.1.1",
         "The next impact-like burst is caused by the start of the motion command. / the "
         "initial acceleration to start the motion generated an impact",
         "peak y_h in the 0.25 s after the stroke's command start minus the median resting "
         "y_h before it (median over stroke-a trials)", "nats", 1.0, math.inf),
    Fact("halted-by-friction", "7.2",
         "The sensor moves slightly forward and then is halted by friction. The third "
         "segment is the slow build up of strain as the position controller ramps up the "
         "torque commands to overcome contact friction.",
         "time from the command start until the finger slides for good (median over "
         "stroke-a trials)", "s", 0.1, 2.0),
    Fact("stop-drop", "7.2",
         "The sixth segment, the short fast drop in strain, is caused by the termination of "
         "the motion command.",
         "time after the command ends until the tangential force falls below half its "
         "sliding level (median over stroke-a trials)", "s", -math.inf, 0.3),
    Fact("resting-wrench", "4.44",
         "E[w_m] = G + E[C_x lambda] - H' v_d (at rest: the shell's weight plus the "
         "constraint force)",
         "relative difference between the measured resting Fz and the contact force plus "
         "the shell weight (stroke-a resting phase)", "", -math.inf, 0.05),
    Fact("impact-at-end", "7.3",
         "The sensor hit and came to rest against a block at the end of its motion.",
         "time of first contact as a fraction of the commanded move (hf-train impact "
         "groups, median)", "", 0.7, 1.2),
    Fact("impact-duration", "7.3.2, fig 7.3",
         "impacts: a step rise in energy followed by a linear decay (H3 runs of 0.3-0.4 s "
         "in the 7.3.2 counts)",
         "median length of the impact (H3) intervals of the hf-train runs", "s", 0.1, 0.6),
    Fact("bounce-train", "4.3.2",
         "in actuality the workpiece bounces several times, in a complex way, before "
         "settling onto the new constraint",
         "contact-gain events in the first impact of the hf-train impact runs (median)", "",
         2.0, math.inf),
    Fact("loss-impact", "4.3.2",
         "If contact is lost abruptly, a contact loss impact occurs because of the sudden "
         "release of this energy.",
         "peak y_h within 0.1 s of losing a 0.5 N contact by sliding over an edge (4.3.2: "
         "'When the orientation of the surface discontinuously changes (i.e. we cross an "
         "edge) ... a loss impact results'), minus the median y_h while pressed", "nats",
         1.0, math.inf),
    Fact("texture-speed", "4.3.1 (4.40)",
         "The magnitude of the variance will depend upon both the direction of travel and "
         "the square of the travel speed.",
         "variance ratio of the strain difference stroking sanded aluminium at twice the "
         "speed", "", 2.0, math.inf),
    Fact("stick-slip-position", "9.1.2",
         "slip as it moved across the flat surface ... the stick-slip that occurs as the "
         "fingertip moves along the surface (low-stiffness position control)",
         "stick-to-slip transitions while the 100 N/m position controller drags the finger "
         "30 mm over wood", "", 3.0, math.inf),
    Fact("no-stick-slip-force", "9.1.3",
         "The integral force controller ... gives measurements that are easier to interpret "
         "than the position controller, because it does not under go stick-slip.",
         "fraction of the sliding period the finger is stuck under the integral force "
         "controller on wood", "", -math.inf, 0.05),
    Fact("force-loop-holds-contact", "9.1.2-9.2",
         "integral endpoint force control presses the finger into the walls of the maze "
         "(commutation ripple of the motors included)",
         "fraction of time in contact while the integral force controller presses 0.2 N "
         "into a Lexan wall and floor", "", 0.99, math.inf),
    Fact("velocity-range", "9.1.1",
         "The second model was a uniform distribution on all the velocities over the "
         "interval [-0.01, 0.01] (M).",
         "fraction of moving guarded-move samples whose measured velocity lies in "
         "+-0.01 m/s on every axis", "", 0.95, math.inf),
    Fact("guarded-move-smooth", "9.1.1",
         "The initial acceleration to start the motion generated an impact. ... The robot is "
         "then smoothly moving and contacts the surface.",
         "fraction of the guarded-move samples from the first moving sample to the first "
         "contact in which the finger is still (speed below 1 mm/s)", "", -math.inf, 0.02),
    Fact("guarded-move-keeps-contact", "9.1.1",
         "This causes an impact (back to feature 1) which then transitions to the final "
         "constraint model (3).",
         "fraction of the guarded-move samples after the contact's impact (its bounce train) "
         "in which the finger touches the surface", "", 0.99, math.inf),
    Fact("guarded-move-exploration-slides", "9.1.1",
         "the system performs well in this experiment because of the exploratory motion added "
         "onto the basic motion. Without exploration the system would not be provided with "
         "sufficient data ... to determine if the other directions were free or constrained.",
         "fraction of the guarded-move contact samples (after the contact's impact) in which "
         "the exploration slides the finger along the surface (speed above 1 mm/s)", "",
         0.5, math.inf),
    Fact("kinematic-error", "8.1.1.2",
         "There is enough kinematic error in the robot to produce a 1 mm deviation from a "
         "straight-line fit to the x and y position data over a maximum of 80 mm.",
         "largest deviation of the recorded x-y positions from their straight-line fit "
         "along an 80 mm slide against a wall", "mm", 0.3, 3.0),
    Fact("corner-window", "9.1.3",
         "An analysis of sticking shows that these three actions will place the fingertip in "
         "the corner for angles between -10 deg and 45 deg.",
         "fraction of the three-guarded-move runs (spec guarded-move-actions) with the YZ "
         "wall at -10, -5, 0, 10, 20, 30, 40 and 45 deg whose finger ends in the table's "
         "corner (the table and both walls touched through the run's last second)", "", 0.99,
         math.inf),
    Fact("corner-stick-below", "9.1.3",
         "For angles less than -10 deg the fingertip will stick to the YZ wall.",
         "fraction of the same runs with the YZ wall at -25 and -20 deg whose finger ends on "
         "the YZ wall short of the corner (YZ wall touched, the other wall not, through the "
         "last second)", "", 0.99, math.inf),
    Fact("corner-integral-force", "9.1.2",
         "With the integral endpoint force controller, command (100, -100, 200) mN, the "
         "expected feature sequence ... through the corner is reliably found.",
         "fraction of the integral-force runs of spec guarded-move-multi (the thesis's "
         "command) whose finger ends in the table's corner (the table and both walls "
         "touched through the run's last second)", "", 0.8, math.inf),
    Fact("wood-slope", "8.1.1.2",
         "A plot of the position data shows that the wood surface was not flat. For some "
         "data sets an 11 deg slope can be observed.",
         "largest slope of a plane fitted to the recorded positions of the cartesian "
         "spec's plane runs", "deg", 3.0, 15.0),
)


def get(name: str) -> Fact:
    for f in FACTS:
        if f.name == name:
            return f
    raise KeyError(f"unknown apparatus fact {name!r}; known: {', '.join(f.name for f in FACTS)}")
