"""Virtual impact campaigns: hammer, sensors, time-domain simulation, FRF estimation, datasets.

::

    cfg = load_config("seed_full")            # or a TOML path
    run_campaign(cfg, "campaign.nc", workers=2)
    ds = open_campaign("campaign.nc")          # xarray Dataset, DATA.md layout
"""

from rmbench.impact.campaign import (Campaign, dry_run, is_complete, postures_of, run_campaign,
                                     run_posture)
from rmbench.impact.config import (CampaignConfig, bundled_configs, default_bands, load_config,
                                   parse_config)
from rmbench.impact.dataset import DATASET_VERSION, open_campaign, save, track_modes
from rmbench.impact.estimate import exponential_window, force_window, h1
from rmbench.impact.hammer import Hit, draw_hit, pulse
from rmbench.impact.measure import band_lines
from rmbench.impact.sensors import SensorSet, sensor_set
from rmbench.impact.summary import CampaignSummary
from rmbench.impact.truth import frf_error_median, nearest_exact_frequency

__all__ = ["Campaign", "CampaignConfig", "load_config", "parse_config", "bundled_configs",
           "run_campaign", "is_complete", "run_posture", "dry_run", "postures_of", "open_campaign", "save",
           "track_modes", "DATASET_VERSION", "Hit", "draw_hit", "pulse", "SensorSet", "sensor_set",
           "force_window", "exponential_window", "h1", "default_bands", "band_lines", "default_lines",
           "CampaignSummary", "frf_error_median", "nearest_exact_frequency"]


def default_lines() -> dict:
    """The spectral lines of the default campaign's bands, Hz: ``{"low": (289,), "high": (401,)}``
    (4-40 Hz every 0.125 Hz, 600-1400 Hz every 2 Hz), for tools that build FRFs on the campaign's
    grid without a campaign file."""
    return {band: band_lines(cfg) for band, cfg in default_bands().items()}
