"""Propagation: radar equation, path loss, walls, RCS, coverage."""

from uwb_env.channel.coverage import blind_zone, cassini_shape_ratio, in_field_of_view, max_range_product
from uwb_env.channel.path_loss import path_gain
from uwb_env.channel.radar_equation import (
    bistatic_radar_constant,
    bistatic_range,
    bistatic_range_rate,
    bistatic_snr,
    direct_path_snr,
    leg_lengths,
    noise_psd,
    snr_on_iso_range,
)
from uwb_env.channel.rcs import rcs_fluctuation
from uwb_env.channel.walls import leg_crossings, leg_obstruction, line_of_sight, pair_obstruction

__all__ = [
    "bistatic_radar_constant",
    "bistatic_range",
    "bistatic_range_rate",
    "bistatic_snr",
    "blind_zone",
    "cassini_shape_ratio",
    "direct_path_snr",
    "in_field_of_view",
    "leg_crossings",
    "leg_lengths",
    "leg_obstruction",
    "line_of_sight",
    "max_range_product",
    "noise_psd",
    "pair_obstruction",
    "path_gain",
    "rcs_fluctuation",
    "snr_on_iso_range",
]
