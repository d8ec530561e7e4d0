"""Campaigns: spec, plan, store, executors (local and Ray), progress, export, replay.

    >>> from navstress.campaign import parse_campaign, plan, preset
    >>> len(plan(parse_campaign(preset("demo")), "/tmp/x").tasks)
    90
"""

from navstress.campaign.plan import Plan, plan
from navstress.campaign.presets import preset, preset_yaml
from navstress.campaign.spec import CampaignSpec, load_campaign, parse_campaign
from navstress.campaign.store import Store

__all__ = ["CampaignSpec", "Plan", "Store", "load_campaign", "parse_campaign", "plan", "preset", "preset_yaml"]
