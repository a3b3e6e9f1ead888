"""Madill's thesis: the first-peak friction identification of section 5.3 (:mod:`.first_peak`, (5.6)–(5.9)),
beside the reproduction of the thesis's numbers (:mod:`.items`)."""
