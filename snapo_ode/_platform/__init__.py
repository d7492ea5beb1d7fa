"""What every other room stands on, free of numerics: input checks (`validation`), strict user
files (`schema`), atomic outputs (`files`), the process-wide JAX settings (`config`) and the
caches' trust (`cache_trust`), devices and processes (`devices`), memory (`resources`), the
stack's versions (`versions`) and lazy public surfaces (`lazy`)."""
