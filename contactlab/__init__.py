"""contactlab: statistical contact sensing for robot manipulation.

An implementation of B. S. Eberman, "Contact Sensing: A Sequential Decision
Approach to Sensing Manipulation Contact Features", MIT AI-TR 1543 (1995).

Subpackages follow the thesis's figure 1.3 / 6.1, one box each:

- :mod:`contactlab.archive`     HDF5 trace archives (format in ``datasets_spec/``)
- :mod:`contactlab.conditioning` signal conditioning of section 7.1
- :mod:`contactlab.estimators`  square-root estimators of appendix A
- :mod:`contactlab.detection`   Page-Hinkley change detection of section 6.3.1
- :mod:`contactlab.experiments` the thesis experiments (``contactlab reproduce``)
- :mod:`contactlab.report`      HTML/PDF reports
"""

__version__ = "0.1.0"
