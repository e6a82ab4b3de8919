"""Reports: experiment pages and archive reports, as HTML with PNG figures plus a PDF."""

from contactlab.report.page import ReportPage

__all__ = ["ReportPage"]
