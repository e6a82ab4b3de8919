"""What each experiment shows and its headline result, ours beside the thesis's.

The same words as the README's table of thesis experiments (a test keeps the
two equal); ``contactlab reproduce --list`` prints them.  An experiment that
is not built yet has an empty headline.
"""

from __future__ import annotations

#: experiment name -> (what it reproduces, headline result)
HEADLINES: dict[str, tuple[str, str]] = {
    'ph-demo': ('Page-Hinkley vs lowpass on a change in mean',
                'detection 143 vs 149, change estimate 124 vs 128'),
    'ph-roc': ('ROC: Wald/Hall approximations vs Monte Carlo',
               'Wald underestimates t_F 3x; PH faster in 11 of 14 settings'),
    'datasets': ("one simulated trial of every dataset beside the thesis's setup",
                 'findings table per dataset'),
    'impact-spectrogram': ('spectrogram of an impact',
                           'ringing 737 Hz (free-base two-mass mode) vs "about 690 Hz" (fixed base)'),
    'ar-fit': ('AR(4) fit of a texture strain',
               'residuals look white, Ljung-Box rejects; AIC/BIC pick 6'),
    'impact-envelope': ('log-energy envelope of an impact',
                        "step then linear decay; slope matches the shell's damping"),
    'stroke-segmentation': ('AR segmentation, threshold sweep, ruptures side by side',
                            'texture boundary only at low thresholds; ruptures more accurate, we are 100-1300x faster'),
    'texture-labelling': ('labelling two-texture samples',
                          'A 95 % (thesis 100 %), B 100 % (thesis 81/97 %); log-energy separates worse than in the thesis'),
    'hf-models': ('high-frequency models',
                  'simulated H0/H1/H2 y_h sit at the converter floor: poorly separated'),
    'hf-recognition': ('the observer with and without context, HMM peer',
                       'well below 81/66/95 % (same cause); the HMM beats the observer here'),
    'cartesian-estimation': ('Cartesian constraint estimation',
                             "constraint form far below the thesis's errors (flat simulated surfaces); stiffness form fails on the line"),
    'polygon-estimation': ('planar polygon estimation',
                           'B, A accurate from length/noise 100, BB 800 (thesis ~100, ~1000)'),
    'constraint-degree': ('degree of constraint',
                          'rich blocks: identity; literal 0.1-s blocks of hand motion mostly undetermined'),
    'constraint-direction': ('direction of constraint',
                             'one contact 88 % at 5 deg, 96 % at 20 deg (thesis >90, >98 %)'),
    'guarded-move': ('guarded move onto a surface',
                     ''),
    'guarded-move-multi': ('guarded move into a corner',
                           ''),
    'guarded-move-actions': ('action-dependent guarded moves',
                             ''),
    'maze': ('the gear-shift maze',
             ''),
}
