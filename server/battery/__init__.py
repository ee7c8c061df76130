"""The device battery (issue 38, docs/battery.md): its parts and the study files built from them."""
