"""Psychophysics, sans-I/O (docs/psychophysics.md): adaptive and fixed procedures whose next
stimulus is a pure function of (spec, seed, answers so far), psychometric functions and their
maximum-likelihood fits with a parametric bootstrap, d′ and criterion, information transfer, and a
synthetic psychometric observer. No clock, no files, no sockets; randomness only from a seed or a
numpy Generator passed in. Procedures need numpy alone; the fits, d′ and the bootstrap use scipy
(the analysis extra)."""
