"""Navigators the tests drive: in process by ``module:attr`` target
(``tests.support.navigators.campaign_navs:Coin``, ``...hostile_nav:Hostile``), and out of
process as scripts speaking the line protocol (``chatty_nav.py``, ``echo_nav.py``,
``hostile_nav.py``, ``misbehaving_nav.py``, ``mission_nav.py``, run by their path)."""
