"""The standard peers our methods are compared with, as library parts.

- :mod:`.ruptures_ar` -- ruptures' Pelt/Binseg with a per-channel AR cost (the
  segmentation peer of 7.2.1)
- :mod:`.hmm` -- a supervised Gaussian HMM decoded by Viterbi (hmmlearn; the
  recognition peer of 7.3)

Importing a peer module imports its library (ruptures, hmmlearn).
"""
