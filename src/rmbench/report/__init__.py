"""Self-contained HTML reports of campaigns, fits, predictions, lobes, RCSA, controllers and gap
diagnoses: interactive plotly figures with their data inlined, one file per run.

::

    from rmbench.report import report_file
    report_file("campaign.nc", "campaign.html")          # kind read from the file

    page = Page("my run")                                 # or compose sections yourself
    campaign_sections(page, ds, fit=fit)
    page.write("run.html")
"""

from rmbench.report.campaign import campaign_sections, dataset_meta, modal_sections
from rmbench.report.page import Page, Section

__all__ = ["Page", "Section", "campaign_sections", "modal_sections", "dataset_meta"]
