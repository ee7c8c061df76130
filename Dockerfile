# ViESTac server with the simulated rig. Real-time priority needs `cap_add: [SYS_NICE]`
# (see docker-compose.yml); without it the loop runs at normal priority and says so.
FROM python:3.11-slim-bookworm
RUN apt-get update && apt-get install -y --no-install-recommends npm gcc libc6-dev make && rm -rf /var/lib/apt/lists/*
WORKDIR /app
COPY . .
RUN python -m venv .venv && .venv/bin/pip install --no-cache-dir -e . \
    && .venv/bin/python -c "from devices.firmware_binding import ensure_library; ensure_library()" \
    && cd clients/web && npm ci --no-audit --no-fund --loglevel=error
EXPOSE 8000
CMD [".venv/bin/viestac", "serve", "--host", "0.0.0.0", "--port", "8000"]
