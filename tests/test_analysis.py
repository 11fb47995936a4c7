"""Block-level analysis: the settings a campaign analyses its cases with, the sub-block
energies that give one block's scatter, and the names that moved to
millscope.campaign_analysis still importable from here."""

from __future__ import annotations

import numpy as np
import pytest

import millscope as ms
import millscope.analysis
import millscope.campaign_analysis
from millscope.analysis import AnalysisSettings, sub_block_energies
from millscope.synthetic import synthetic_record

from .synthetic_campaign import content_for


def test_sub_block_energies_count_and_short_blocks() -> None:
    scene = ms.presets.pilot_mill(0.71, "ceramic", 2, scale="tiny")
    block = synthetic_record(2, content=content_for(scene)).block(4, 14)
    parts = sub_block_energies(block, lth_hz=16 * scene.rotation_hz, sub_blocks=10)
    assert parts is not None and parts.shape == (10,) and np.all(parts > 0)
    # 10 s at 100 Hz: at most 1000 // 32 = 31 sub-blocks of 32 samples
    assert sub_block_energies(block, lth_hz=None, sub_blocks=50).shape == (31,)
    assert sub_block_energies(block.block(4, 4.95), lth_hz=None) is None  # 95 samples < 3 x 32
    with pytest.raises(ValueError, match="sub_blocks = 0"):
        sub_block_energies(block, lth_hz=None, sub_blocks=0)


def test_analysis_settings_validate_and_round_trip() -> None:
    s = AnalysisSettings((4, 14), 0.3, "hann")
    assert s.block == (4.0, 14.0) and s.block_s == 10.0
    assert AnalysisSettings.from_dict(s.to_dict()) == s
    with pytest.raises(ValueError, match="block = .* 0 <= t1 < t2"):
        AnalysisSettings((5.0, 4.0))
    with pytest.raises(ValueError, match="bandwidth = 0"):
        AnalysisSettings((0.0, 1.0), 0)
    with pytest.raises(ValueError, match="window = 'hamming'"):
        AnalysisSettings((0.0, 1.0), window="hamming")
    with pytest.raises(ValueError, match="keys block, bandwidth, window"):
        AnalysisSettings.from_dict({"block": [0, 1]})


def test_the_campaign_analysis_is_still_importable_from_analysis() -> None:
    """Code written before the split imports these from millscope.analysis."""
    from millscope.analysis import GroupAnalysis, analyze_campaign, table6_markdown

    moved = millscope.campaign_analysis
    assert analyze_campaign is moved.analyze_campaign is ms.analyze_campaign
    assert GroupAnalysis is moved.GroupAnalysis and table6_markdown is moved.table6_markdown
    with pytest.raises(AttributeError, match="has no attribute 'nothing_here'"):
        _ = millscope.analysis.nothing_here
