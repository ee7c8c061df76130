"""The pure core: geometry, god-object, contact gate, scene, cues, the scenario interface and the
loop's records. Everything may import it; it imports nothing of ViESTac above it (enforced by the
import-linter contracts in pyproject.toml, docs/architecture.md "Layers")."""
