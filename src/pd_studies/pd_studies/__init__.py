"""The thesis's studies, run offline on the core.

The chapter 5 comparison (:mod:`.study_ch5`) and the growth of experimental errors
(:mod:`.study_errors`).
"""
