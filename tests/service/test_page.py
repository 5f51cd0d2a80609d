"""The page at / in a real browser: Debian's chromium driven by Playwright, against a real
`python -m raydamp_service`. Playwright's own browser download cannot work here, so the test
launches /usr/bin/chromium; when it cannot start, the test fails with the reason (never a skip).

The screenshot of the Kepler run is written to docs/page.png (the README shows it).
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

CHROMIUM = "/usr/bin/chromium"
SCREENSHOT = Path(__file__).resolve().parents[2] / "docs" / "page.png"
RUN_TIMEOUT_MS = 120_000  # a loaded machine is slow, not red
SERVER_ENV = {"RAYDAMP_MAX_STEPS": str(10**10)}  # a run the cancel test can never see finish


@contextmanager
def chromium() -> Iterator:
    try:
        from playwright.sync_api import sync_playwright
    except ImportError as error:
        pytest.fail(f"playwright is not installed ({error}); `make test` installs it with the test extra")
    with sync_playwright() as playwright:
        try:
            browser = playwright.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        except Exception as error:  # noqa: BLE001 - any reason the browser did not start fails the test with it
            pytest.fail(f"{CHROMIUM} did not start ({error}); `make test` installs the Debian package chromium")
        try:
            yield browser
        finally:
            browser.close()


@contextmanager
def open_page(base: str, path: str = "/") -> Iterator:
    """A page on the service that records every URL it requests and every script error."""
    with chromium() as browser:
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        requests: list[str] = []
        errors: list[str] = []
        page.on("request", lambda request: requests.append(request.url))
        page.on("pageerror", lambda error: errors.append(str(error)))
        page.goto(base + path)
        yield page
        assert errors == [], errors
        outside = [url for url in requests if not url.startswith(base + "/")]
        assert outside == [], f"the page loaded from other hosts: {outside}"


def _base(server) -> str:
    return f"http://127.0.0.1:{server.port}"


def _ready(page) -> None:
    page.wait_for_selector('body[data-ready="true"]', timeout=30_000)


def _run(page, previous: str | None = None) -> str:
    """Click Run and wait until the plots of the new job are drawn; its id."""
    page.click("#submit")
    page.wait_for_function(
        "previous => { const plots = document.getElementById('plots');"
        " return plots.dataset.job && plots.dataset.job !== previous && plots.dataset.ready === 'true'; }",
        arg=previous or "", timeout=RUN_TIMEOUT_MS)
    return page.eval_on_selector("#plots", "plots => plots.dataset.job")


def _show(page, job_id: str) -> None:
    """Open a listed job's plots and wait until they are drawn."""
    page.wait_for_selector(f'#jobs tr[data-job="{job_id}"] button.show', timeout=30_000)
    page.click(f'#jobs tr[data-job="{job_id}"] button.show')
    page.wait_for_function("id => { const plots = document.getElementById('plots');"
                           " return plots.dataset.job === id && plots.dataset.ready === 'true'; }",
                           arg=job_id, timeout=RUN_TIMEOUT_MS)


def _traces(page, plot: str) -> list[dict]:
    """Plotly's own record of what it drew (gd.data): name and the x, y arrays of each trace."""
    return page.eval_on_selector(f"#plot-{plot}",
                                 "gd => (gd.data || []).map(t => "
                                 "({name: t.name, x: Array.from(t.x), y: Array.from(t.y)}))")


def _drawn(page, plot: str) -> bool:
    """Visible and holding an SVG Plotly drew (not just a div with data)."""
    return page.eval_on_selector(f"#plot-{plot}", "gd => !gd.hidden && gd.querySelector('svg.main-svg') !== null")


def test_kepler_run_through_the_form(module_server) -> None:
    """A user's system from the JSON editor: submit, progress to 100 %, four plots with the right
    traces holding the service's numbers, download links, the run in the list; screenshot."""
    base = _base(module_server)
    with open_page(base) as page:
        _ready(page)
        page.check("input[name=source][value=system]")
        page.select_option("#example", label="Kepler orbit with a dashpot on the radius")
        assert '"potential": "-1/sqrt(x^2 + y^2)"' in page.input_value("#system")
        assert page.is_hidden("#tableau-label")  # 2s has no tableau to choose
        job_id = _run(page)

        job = module_server.job(job_id)
        assert job["status"] == "completed" and job["spec"]["system"]["name"] == "kepler with drag"
        assert page.eval_on_selector("#progress", "bar => bar.value") == 1.0
        assert page.inner_text("#job-status") == "completed"

        points = job["summary"]["saved_points"]
        energy = _traces(page, "energy")
        assert len(energy) == 1 and len(energy[0]["x"]) == points
        # H(q0, p0) = |p0|^2 / 2 - 1 / |q0| = 0.72 - 1; the last point is the service's final energy.
        assert energy[0]["y"][0] == pytest.approx(-0.28, abs=1e-12)
        assert energy[0]["y"][-1] == pytest.approx(job["summary"]["energy_final"], rel=1e-12)
        assert energy[0]["y"][-1] < energy[0]["y"][0]  # the dashpot took energy out

        # The energy balance H - H0 + W drawn from the service's own H and W, small against what was dissipated.
        data = module_server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
        balance = _traces(page, "balance")
        assert len(balance) == 1 and len(balance[0]["y"]) == points
        expected = [e - data["energy"][0] + w for e, w in zip(data["energy"], data["work"])]
        assert balance[0]["y"] == pytest.approx(expected, abs=1e-15)
        assert max(map(abs, expected)) < 1e-3 * (data["energy"][0] - data["energy"][-1])

        phase = _traces(page, "phase")
        assert [trace["name"] for trace in phase] == ["(x, p_x)", "(y, p_y)"]
        assert phase[0]["x"][0] == 1.0 and phase[1]["y"][0] == 1.2  # (q0, p0) per coordinate
        assert page.eval_on_selector_all("#displacement-dof option", "options => options.map(o => o.textContent)") \
            == ["x", "y"]

        projection = _traces(page, "projection")
        assert len(projection) == 1 and projection[0]["x"][0] == 1.0 and projection[0]["y"][0] == 0.0

        # 2s conserves the angular momentum to rounding (the README's ~1e-13): the drift plotted is that.
        drift = _traces(page, "momentum")
        assert [trace["name"] for trace in drift] == ["L(t) - L(0)"]
        assert max(abs(value) for value in drift[0]["y"]) < 1e-10
        assert all(_drawn(page, plot) for plot in ("energy", "balance", "phase", "projection", "momentum"))

        links = page.eval_on_selector_all("#downloads a[data-format]",
                                          "links => links.map(a => a.getAttribute('href'))")
        assert links == [f"/v1/jobs/{job_id}/trajectory?format={fmt}" for fmt in ("json", "csv", "npz", "netcdf")]
        csv = module_server.client.get(links[1])
        assert csv.status_code == 200 and csv.text.count("\n") >= points

        page.wait_for_selector(f'#jobs tr[data-job="{job_id}"] td.status-completed', timeout=30_000)
        SCREENSHOT.parent.mkdir(exist_ok=True)
        page.screenshot(path=str(SCREENSHOT), full_page=True)


def test_models_overlay_and_delete(module_server) -> None:
    """A built-in model (3-D: three phase portraits, a projection, J3's drift), then the 1-D pendulum
    overlaid on its energy plot (no projection, no momentum plot); deleting runs from the list."""
    base = _base(module_server)
    with open_page(base) as page:
        _ready(page)
        page.select_option("#model", "elastic_pendulum")
        assert page.input_value("#q") == "0, 1.55884573, -0.6"  # the paper's section 6.2 data
        elastic = _run(page)
        assert module_server.job(elastic)["spec"]["model"] == "elastic_pendulum"
        assert len(_traces(page, "phase")) == 3
        assert len(_traces(page, "projection")) == 1 and len(_traces(page, "momentum")) == 1

        page.check("#overlay")
        page.select_option("#model", "damped_pendulum")
        page.select_option("#method", "rks")
        assert page.is_visible("#tableau") and page.input_value("#tableau") == "heun"  # rks's default
        assert page.eval_on_selector_all("#tableau option", "options => options.map(o => o.value)") == [
            "euler", "heun", "midpoint", "rk4"]
        assert page.is_hidden("#composition-label")  # heun is not symmetric: nothing to compose
        page.select_option("#tableau", "midpoint")
        assert page.is_visible("#composition-label")
        page.select_option("#method", "2s")
        assert page.is_hidden("#tableau-label") and page.is_visible("#composition-label")
        page.select_option("#composition", "yoshida4")
        pendulum = _run(page, previous=elastic)
        job = module_server.job(pendulum)
        assert job["spec"]["method"] == "2s" and job["status"] == "completed"
        assert job["spec"]["composition"] == "yoshida4" and job["summary"]["composition"] == "yoshida4"
        energy = _traces(page, "energy")
        assert len(energy) == 2  # the elastic pendulum's curve kept, the pendulum's added
        assert energy[1]["name"] == "damped_pendulum 2s ∘ yoshida4 h=0.1"
        assert energy[1]["y"][0] == pytest.approx(1 - math.cos(2.827433388), abs=1e-9)
        assert len(_traces(page, "phase")) == 1
        assert page.eval_on_selector("#plot-projection", "gd => gd.hidden")
        assert page.eval_on_selector("#plot-momentum", "gd => gd.hidden")

        page.wait_for_selector(f'#jobs tr[data-job="{elastic}"] td.status-completed', timeout=30_000)
        page.click(f'#jobs tr[data-job="{elastic}"] button.delete')
        page.wait_for_selector(f'#jobs tr[data-job="{elastic}"]', state="detached", timeout=30_000)
        assert module_server.client.get(f"/v1/jobs/{elastic}").status_code == 404


def test_invalid_spec_shows_the_json_path(module_server) -> None:
    """The service's 422 is shown next to the form with the path inside the spec, and the field it
    names is outlined; JSON that does not parse is caught before sending."""
    base = _base(module_server)
    with open_page(base) as page:
        _ready(page)
        ids_before = [job["id"] for job in module_server.client.get("/v1/jobs").json()["jobs"]]
        page.check("input[name=source][value=system]")
        page.select_option("#example", label="damped pendulum")
        page.fill("#system", page.input_value("#system").replace("1 - cos(theta)", "1 - cos(theta"))
        page.click("#submit")
        page.wait_for_selector("#errors:not([hidden])", timeout=30_000)
        assert page.inner_text("#errors code") == "system.potential"
        assert page.inner_text("#errors").count("system.potential") == 1  # the path once (issue 27)
        assert "system" in page.eval_on_selector_all(".invalid", "controls => controls.map(c => c.id)")

        page.fill("#system", page.input_value("#system").replace("cos(theta", "cos(theta)"))
        page.fill("#step_size", "-0.1")
        page.click("#submit")
        page.wait_for_function("() => document.querySelector('#errors code').textContent === 'step_size'",
                               timeout=30_000)
        assert "greater than 0" in page.inner_text("#errors")

        page.fill("#system", "{not json")
        page.click("#submit")
        page.wait_for_function("() => document.querySelector('#errors code').textContent === 'system'",
                               timeout=30_000)
        assert "not valid JSON" in page.inner_text("#errors")
        ids = [job["id"] for job in module_server.client.get("/v1/jobs").json()["jobs"]]
        assert ids == ids_before  # none of the three was queued


def test_docs_are_served_locally(module_server) -> None:
    """/docs references no external host, and Swagger UI renders the API from the local bundle."""
    html = module_server.client.get("/docs").text
    referenced = re.findall(r"""(?:src|href|url)\s*[=:]\s*["']([^"']+)["']""", html)
    assert referenced, html
    assert [url for url in referenced if "//" in url] == [], html
    assert not re.search(r"https?://", html), html
    for url in referenced:
        assert module_server.client.get(url).status_code == 200, url
    with open_page(_base(module_server), "/docs") as page:
        # Swagger UI read /openapi.json (3.1, which an old bundled Swagger UI refuses to render).
        page.wait_for_selector(".swagger-ui .info .title", timeout=30_000)
        assert page.inner_text(".swagger-ui .info .title").startswith("raydamp")
        page.wait_for_selector('.opblock-summary-path[data-path="/v1/jobs/{job_id}/trajectory"]', timeout=30_000)


def test_every_example_runs(module_server) -> None:
    """The editor's examples are specs the service accepts and completes, and the suggested starts
    are for models the service has, with their dimension."""
    examples = module_server.client.get("/static/examples.json").json()
    models = {model["name"]: model for model in module_server.client.get("/v1/models").json()}
    for name, start in examples["models"].items():
        assert name in models and len(start["q"]) == len(start["p"]) == models[name]["dim"], name
    for example in examples["systems"]:
        spec = {"system": example["system"], "method": example["method"], "step_size": example["step_size"],
                "t_end": example["t_end"], "save_every": example["save_every"],
                "initial_state": {"q": example["q"], "p": example["p"]}}
        job = module_server.wait_finished(module_server.submit(spec))
        assert job["status"] == "completed", (example["label"], job["error"])
        # Damped, so each example loses energy: the plots show something happening.
        assert job["summary"]["energy_dissipated"] > 0, example["label"]


def test_progress_is_live_and_cancel_stops_the_run(module_server) -> None:
    """A long run: the bar shows a fraction strictly between 0 and 1 while it runs (the service's
    live progress), Cancel stops it, and what it computed is still plotted."""
    base = _base(module_server)
    with open_page(base) as page:
        _ready(page)
        page.select_option("#model", "damped_pendulum")
        page.fill("#step_size", "0.001")
        page.fill("#t_end", "10000000")  # 10^10 steps: hours, far longer than the test waits
        page.fill("#save_every", "100000")
        page.click("#submit")
        page.wait_for_function("() => { const bar = document.getElementById('progress');"
                               " return bar.value > 0 && bar.value < 1; }", timeout=RUN_TIMEOUT_MS)
        assert page.inner_text("#job-status") == "running"
        # The click waits for the button as long as the run's own waits do: on a loaded host the
        # browser took over 30 s (Playwright's default) to make it actionable (fresh clone, 2026-11-29).
        page.click("#cancel", timeout=RUN_TIMEOUT_MS)
        page.wait_for_function("() => document.getElementById('plots').dataset.ready === 'true'",
                               timeout=RUN_TIMEOUT_MS)
        job = module_server.job(page.inner_text("#job-id"))
        assert job["status"] == "cancelled" and 0 < job["progress"] < 1
        energy = _traces(page, "energy")
        saved = job["summary"]["saved_points"]
        assert saved > 1
        # The page fetches every k-th point, k = ceil(saved / 5000), for its plots.
        assert len(energy[0]["x"]) == len(range(0, saved, -(-saved // 5000)))


def test_a_service_with_a_token(start_server, tmp_path) -> None:
    """RAYDAMP_TOKEN set: the page loads, asks for the token (a wrong one is refused), then runs a
    job with it; a download, which a plain link could not authorise, is fetched with the token."""
    server = start_server(RAYDAMP_TOKEN="page-s3cret")
    base = _base(server)
    with open_page(base) as page:
        page.wait_for_selector("#token-form:not([hidden])", timeout=30_000)
        assert page.get_attribute("body", "data-ready") is None  # nothing loaded without the token
        page.fill("#token", "wrong")
        page.click("#token-submit")
        page.wait_for_function("() => document.getElementById('token-message').textContent.includes('refused')",
                               timeout=30_000)
        page.fill("#token", "page-s3cret")
        page.click("#token-submit")
        _ready(page)
        assert page.is_hidden("#token-form")
        job_id = _run(page)
        assert server.job(job_id)["status"] == "completed"
        with page.expect_download(timeout=30_000) as download:
            page.click('#downloads a[data-format="csv"]')
        saved = tmp_path / "download.csv"
        download.value.save_as(saved)
        assert saved.read_text() == server.client.get(f"/v1/jobs/{job_id}/trajectory?format=csv").text
        assert download.value.suggested_filename == f"{job_id}-trajectory.csv"


AT2_RECORD = """PEER NGA STRONG MOTION DATABASE RECORD
PAGE TEST, 1 JAN 2000, SYNTHETIC, 0
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=   400, DT=   .0500 SEC
""" + "".join(f"{0.05 * math.sin(0.3 * k) * math.exp(-0.01 * k):15.7E}" + ("\n" if k % 5 == 4 else "")
              for k in range(400))


def test_a_harmonic_load_and_a_record_as_ground_motion(module_server) -> None:
    """The Load controls: a harmonic force on the pendulum, then an uploaded .AT2 record as ground motion (a
    malformed one refused with its reason); each run plots the energy budget from the service's numbers:
    W_f, W, H - H0, and the residual H - H0 + W - W_f, small against the energy the load put in."""
    base = _base(module_server)
    with open_page(base) as page:
        _ready(page)
        page.select_option("#model", "damped_pendulum")
        assert page.is_hidden("#harmonic-fields") and page.is_hidden("#ground-fields")
        page.select_option("#load-kind", "harmonic")
        assert page.input_value("#load-amplitude") == "0.1"  # sized to the model: one coordinate
        page.fill("#load-omega", "0.8")
        forced = _run(page)
        job = module_server.job(forced)
        assert job["status"] == "completed"
        assert job["spec"]["load"] == {"harmonic": {"amplitude": [0.1], "omega": 0.8}}

        data = module_server.client.get(f"/v1/jobs/{forced}/trajectory").json()
        budget = _traces(page, "budget")
        assert [trace["name"] for trace in budget] == ["W_f (load's work)", "W (damping's work)", "H - H0"]
        assert budget[0]["y"] == data["load_work"] and budget[1]["y"] == data["work"]
        assert budget[0]["y"][-1] == pytest.approx(job["summary"]["load_work_final"], rel=1e-12)
        residual = _traces(page, "balance")
        assert residual[0]["name"].startswith("H - H0 + W - W_f, damped_pendulum 3s h=0.1 + load")
        expected = [e - data["energy"][0] + w - f for e, w, f in zip(data["energy"], data["work"], data["load_work"])]
        assert residual[0]["y"] == pytest.approx(expected, abs=1e-15)
        # O(h^2) at h = 0.1: 0.17 % of the work the force did.
        assert max(map(abs, expected)) < 5e-3 * max(map(abs, data["load_work"]))
        assert max(map(abs, data["load_work"])) > 0.05
        assert _drawn(page, "budget") and _drawn(page, "balance")
        assert "load work W_f" in page.inner_text("#summary")
        # Under a load H0 - H is no dissipation (the page showed "energy dissipated -1.53" beside a damping work
        # of 616,012): the row is the damping work W, the summary's energy_dissipated, W at the end.
        rows = dict(line.split("\t") for line in page.inner_text("#summary").splitlines())
        assert "energy dissipated" not in rows and job["summary"]["energy_dissipated"] == job["summary"]["work_final"]
        assert float(rows["damping work W"]) == pytest.approx(data["work"][-1], rel=1e-5) and data["work"][-1] > 0

        page.select_option("#load-kind", "ground")
        bad = AT2_RECORD.replace("NPTS=   400", "NPTS=   401")
        page.set_input_files("#record-file", files=[{"name": "BAD.AT2", "mimeType": "text/plain",
                                                      "buffer": bad.encode()}])
        page.wait_for_function("() => document.body.dataset.uploaded === '1'", timeout=30_000)
        assert "NPTS=401 but the record has 400 values" in page.inner_text("#record-message")
        page.set_input_files("#record-file", files=[{"name": "PAGE.AT2", "mimeType": "text/plain",
                                                      "buffer": AT2_RECORD.encode()}])
        page.wait_for_function("() => document.body.dataset.uploaded === '2'", timeout=30_000)
        assert "uploaded PAGE.AT2 (400 samples, dt 0.05" in page.inner_text("#record-message")
        page.wait_for_function("() => document.getElementById('record').selectedOptions.length === 1", timeout=30_000)
        record_id = page.input_value("#record")
        assert module_server.client.get(f"/v1/files/{record_id}").json()["name"] == "PAGE.AT2"
        assert page.input_value("#record-direction") == "1"
        # h below the record's dt = 0.05, so that the kicks resolve its samples.
        page.fill("#step_size", "0.01")
        page.fill("#t_end", "30")
        page.fill("#save_every", "10")
        shaken = _run(page, previous=forced)
        job = module_server.job(shaken)
        assert job["status"] == "completed"
        assert job["spec"]["ground_motion"] == {"acceleration": {"file": {"id": record_id, "factor": 9.81}},
                                                "direction": [1]}
        assert "load" not in job["spec"] or job["spec"]["load"] is None
        data = module_server.client.get(f"/v1/jobs/{shaken}/trajectory").json()
        budget = _traces(page, "budget")
        assert budget[0]["y"] == data["load_work"] and max(map(abs, data["load_work"])) > 1e-3
        expected = [e - data["energy"][0] + w - f for e, w, f in zip(data["energy"], data["work"], data["load_work"])]
        assert max(map(abs, expected)) < 1e-3 * max(map(abs, data["load_work"]))  # 3.3e-4 at h = 0.01
        # The record is in use by no queued job any more: it can be deleted.
        assert module_server.client.delete(f"/v1/files/{record_id}").status_code == 204


def test_a_run_at_a_temperature(module_server) -> None:
    """The Thermal noise controls: kT and a seed typed in reach the service exactly (a seed near 2^64, beyond
    a JavaScript number's 2^53); a run without a seed shows the seed the service drew, digit for digit; the
    summary shows the kinetic temperature of a long damped pendulum run at kT = 0.5 (3s, h = 0.1, eps = 0.5:
    p relaxes in 2 time units): over 2000 points 5 apart (about 1700 independent ones), 4 standard errors are
    4 sqrt(2 / 1700) kT = 14 % of kT."""
    base = _base(module_server)
    kT = 0.5
    with open_page(base) as page:
        _ready(page)
        page.select_option("#model", "damped_pendulum")
        page.fill("#parameters", '{"eps": 0.5}')
        page.fill("#step_size", "0.1")
        page.fill("#t_end", "20000")
        page.fill("#save_every", "10")
        assert page.is_hidden("#job-thermal") or page.is_hidden("#job")
        page.fill("#temperature", "0.5")
        page.fill("#seed", "18446744073709551557")
        given = _run(page)
        job = module_server.job(given)
        assert job["status"] == "completed"
        assert job["spec"]["temperature"] == kT and job["spec"]["seed"] == 18446744073709551557
        assert page.inner_text("#job-seed") == "18446744073709551557"
        kinetic = job["summary"]["kinetic_temperature"]
        assert abs(kinetic - kT) <= 4 * math.sqrt(2 / 1700) * kT, kinetic
        # H - H0 + W leaves out the energy the noise brings: no balance to plot at a temperature
        assert page.is_hidden("#plot-balance") and _drawn(page, "energy")
        rows = dict(line.split("\t") for line in page.inner_text("#summary").splitlines())
        assert float(rows["kinetic temperature"]) == pytest.approx(kinetic, rel=1e-5)  # shown to 6 digits

        page.fill("#seed", "")
        page.fill("#t_end", "100")
        drawn = _run(page, previous=given)
        job = module_server.job(drawn)
        seed = job["spec"]["seed"]  # drawn at submission from [0, 2^64), kept with the job
        assert isinstance(seed, int) and page.inner_text("#job-seed") == str(seed)
        assert page.inner_text("#job-temperature") == "0.5"

        page.fill("#temperature", "-1")
        page.click("#submit")
        page.wait_for_selector("#errors:not([hidden])", timeout=30_000)
        assert page.inner_text("#errors").startswith("temperature")
        assert page.eval_on_selector("#temperature", "input => input.classList.contains('invalid')")


def test_a_decimated_plot_ends_at_the_last_point_and_names_are_text(module_server) -> None:
    """Audit: past 5,000 saved points the page fetched every k-th one, and the last (the run's end, or a
    blow-up's last finite state) was not drawn unless k divided the count; a system's name went to Plotly,
    which reads <b> and <a> in a trace's name as its own markup."""
    name = '<b>bold</b> <a href="x">link</a>'
    spec = {"system": {"coordinates": ["x"], "potential": "x^2/2", "damping": {"scalar": 1.0}, "eps": 0.1,
                       "name": name},
            "method": "3s", "step_size": 0.01, "n_steps": 10_003, "initial_state": {"q": [1.0], "p": [0.0]}}
    job_id = module_server.submit(spec)
    job = module_server.wait_finished(job_id)
    assert job["status"] == "completed" and job["summary"]["saved_points"] == 10_004  # drawn every 3rd
    with open_page(_base(module_server)) as page:
        _ready(page)
        _show(page, job_id)
        energy = _traces(page, "energy")[0]
        assert energy["x"][-1] == job["summary"]["t_final"] and len(energy["x"]) == 3336  # 3,335 every 3rd + last
        assert page.is_hidden("#jobs-more")  # fewer than 100 jobs: nothing more to say

        # A blow-up's message names its step: the page said it twice ("... at step 10 ... (step 10)").
        blown = module_server.submit({**spec, "system": {**spec["system"], "potential": "-x^4"}, "n_steps": 100,
                                      "step_size": 0.1, "initial_state": {"q": [2.0], "p": [0.0]}})
        failed = module_server.wait_finished(blown)
        assert failed["status"] == "failed" and failed["failed_step"] is not None
        page.click("#refresh")
        _show(page, blown)
        shown = page.text_content("#job-error")
        assert shown == failed["error"] and shown.count(f"step {failed['failed_step']}") == 1, shown
        # Escaped for Plotly, which then shows the name as written (its legend, its hover), not as markup.
        assert energy["name"].startswith(
            "&lt;b&gt;bold&lt;/b&gt; &lt;a href=\"x\"&gt;link&lt;/a&gt; 3s"), energy["name"]


def test_a_displacement_plot_with_a_choice_of_coordinate(module_server) -> None:
    """The first plot an engineer looks for: q_k(t) of one coordinate, chosen from a list of the saved ones. A
    4-storey shear frame (unit masses and storey springs) under a harmonic force on its roof, saving storeys 2 and
    4 (save_dofs [3, 1]): the list names them q3 and q1 in that order, the roof (q3, which moves most) is drawn
    first, and choosing q1 draws its column, both the service's numbers. Screenshot: build/page-displacement.png."""
    k = {"coo": {"shape": [4, 4], "rows": [0, 0, 1, 1, 1, 2, 2, 2, 3, 3], "cols": [0, 1, 0, 1, 2, 1, 2, 3, 2, 3],
                 "values": [2, -1, -1, 2, -1, -1, 2, -1, -1, 1]}}
    spec = {"system": {"kind": "linear_structure", "M": {"diagonal": [1, 1, 1, 1]}, "K": k, "alpha": 0.05},
            "load": {"harmonic": {"amplitude": [0, 0, 0, 0.1], "omega": 0.5}}, "method": "gauss4", "h": 0.05,
            "t_end": 60, "save_every": 4, "save_dofs": [3, 1], "initial_state": {"rest": True}}
    job_id = module_server.submit(spec)
    assert module_server.wait_finished(job_id)["status"] == "completed"
    data = module_server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    with open_page(_base(module_server)) as page:
        _ready(page)
        _show(page, job_id)
        options = page.eval_on_selector_all("#displacement-dof option", "options => options.map(o => o.textContent)")
        assert options == ["q3", "q1"]
        assert page.input_value("#displacement-dof") == "0"  # the roof: its peak is the larger
        roof = [row[0] for row in data["q"]]
        assert max(map(abs, roof)) > max(abs(row[1]) for row in data["q"]) > 0.01
        drawn = _traces(page, "displacement")
        assert len(drawn) == 1 and drawn[0]["x"] == data["t"] and drawn[0]["y"] == roof
        assert _drawn(page, "displacement")
        assert page.eval_on_selector("#plot-displacement", "gd => gd.layout.title.text") == "displacement q3(t)"
        shot = SCREENSHOT.parents[1] / "build" / "page-displacement.png"
        shot.parent.mkdir(exist_ok=True)
        page.screenshot(path=str(shot), full_page=True)
        page.select_option("#displacement-dof", label="q1")
        page.wait_for_function("() => document.getElementById('plot-displacement').layout.title.text"
                               " === 'displacement q1(t)'", timeout=30_000)
        assert _traces(page, "displacement")[0]["y"] == [row[1] for row in data["q"]]
        assert [trace["name"] for trace in _traces(page, "phase")] == ["(q3, p_q3)", "(q1, p_q1)"]
        assert data["spring_forces"] is None and page.is_hidden("#spring-loop")  # no springs: no loop


def test_event_crossings_are_marked_on_the_displacement_plot(module_server) -> None:
    """A pendulum job with events: each crossing the summary lists is a marker on q(t), at its own time and q."""
    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "h": 0.01, "t_end": 12,
            "save_every": 10, "initial_state": {"q": [1.0], "p": [0.0]},
            "events": [{"g": "q[0]", "name": "vertical"}, {"g": "q[0] - 0.5", "direction": 1, "name": "half"}]}
    job_id = module_server.submit(spec)
    job = module_server.wait_finished(job_id)
    assert job["status"] == "completed"
    events = job["summary"]["events"]
    assert events["count"] >= 4
    with open_page(_base(module_server)) as page:
        _ready(page)
        _show(page, job_id)
        drawn = _traces(page, "displacement")
        assert [trace["name"] for trace in drawn][1:] == ["events"]
        assert drawn[1]["x"] == events["t"] and drawn[1]["y"] == [row[0] for row in events["q"]]


def test_a_structures_spring_has_its_force_deformation_loop(module_server) -> None:
    """A 2-storey frame of elastic-perfectly-plastic storeys under a harmonic force on its roof: the page lists its
    springs, draws the loop of the one that deforms most (the base storey) from the service's spring_forces and
    spring_deformations, and another on choosing it. The loop is hysteretic: its force stops at fy, and it encloses
    the work the storey dissipated; the energy budget counts the springs' hysteretic work. Screenshot:
    build/page-loop.png."""
    spring = {"kind": "elastic_plastic", "k": 40.0, "fy": 1.0}
    spec = {"work": True, "system": {"kind": "structure", "M": {"diagonal": [1.0, 1.0]}, "alpha": 0.1,
                       "springs": [{"dofs": [0, 1], "material": {**spring, "fy": 1.5}},
                                   {"dofs": [0], "material": spring}]},
            "load": {"harmonic": {"amplitude": [0.0, 1.2], "omega": 3.0}}, "method": "3s", "h": 0.01, "t_end": 20,
            "save_every": 2, "initial_state": {"rest": True}}
    job_id = module_server.submit(spec)
    assert module_server.wait_finished(job_id)["status"] == "completed"
    data = module_server.client.get(f"/v1/jobs/{job_id}/trajectory").json()
    forces, drifts = data["spring_forces"], data["spring_deformations"]
    assert len(forces) == len(drifts) == len(data["t"]) and len(forces[0]) == 2
    assert drifts == [[q[1] - q[0], q[0]] for q in data["q"]]
    base = [row[1] for row in forces]
    assert max(map(abs, base)) == pytest.approx(1.0, rel=1e-14)  # the base storey yielded: its force stops at fy
    with open_page(_base(module_server)) as page:
        _ready(page)
        _show(page, job_id)
        assert page.eval_on_selector_all("#loop-spring option", "options => options.map(o => o.textContent)") \
            == ["springs[0]: q0 to q1", "springs[1]: q0 to the ground"]
        assert page.input_value("#loop-spring") == "1"  # the base storey: its largest |d| is the larger
        drawn = _traces(page, "loop")
        assert len(drawn) == 1 and drawn[0]["x"] == [row[1] for row in drifts] and drawn[0]["y"] == base
        assert _drawn(page, "loop")
        # the loop's area, the work it dissipated: positive, and a yielded storey's (an elastic one's is 0)
        area = sum(0.5 * (f0 + f1) * (d1 - d0) for f0, f1, d0, d1 in
                   zip(drawn[0]["y"], drawn[0]["y"][1:], drawn[0]["x"], drawn[0]["x"][1:]))
        assert area > 0.1
        # the budget counts the springs' hysteretic work: W_f = H - H0 + W + sum W_h, closed to O(h^2)
        hysteretic = [sum(row) for row in data["hysteretic_work"]]
        budget = _traces(page, "budget")
        assert [trace["name"] for trace in budget] == ["W_f (load's work)", "W (damping's work)",
                                                       "ΣW_h (springs' hysteretic work)", "H - H0"]
        assert budget[2]["y"] == hysteretic and hysteretic[-1] > 0.1
        residual = _traces(page, "balance")[0]
        assert residual["name"].startswith("H - H0 + W + ΣW_h - W_f, structure 3s")
        expected = [e - data["energy"][0] + w + wh - wf for e, w, wh, wf in
                    zip(data["energy"], data["work"], hysteretic, data["load_work"])]
        assert residual["y"] == pytest.approx(expected, abs=1e-12)
        assert max(map(abs, expected)) < 1e-3 * max(data["load_work"])  # measured 8.4e-5 of it
        shot = SCREENSHOT.parents[1] / "build" / "page-loop.png"
        shot.parent.mkdir(exist_ok=True)
        page.screenshot(path=str(shot), full_page=True)
        page.select_option("#loop-spring", label="springs[0]: q0 to q1")
        page.wait_for_function("() => document.getElementById('plot-loop').layout.title.text"
                               " === 'force-deformation loop of springs[0]: q0 to q1'", timeout=30_000)
        assert _traces(page, "loop")[0]["y"] == [row[0] for row in forces]

        # newmark runs a Structure with springs only (GET /v1/structure_methods): the method menu offers it while
        # the system edited is one, with its description, and takes it back when the springs go.
        def offered() -> list[str]:
            return page.eval_on_selector_all("#method option", "options => options.map(o => o.value)")

        page.check("input[name=source][value=system]")
        assert "3s" in offered() and "newmark" not in offered()  # the first example: a pendulum
        page.fill("#system", json.dumps(spec["system"]))
        page.wait_for_function("() => [...document.querySelectorAll('#method option')]"
                               ".some(o => o.value === 'newmark')", timeout=30_000)
        page.select_option("#method", "newmark")
        [newmark] = module_server.client.get("/v1/structure_methods").json()
        assert page.inner_text("#method-description") == newmark["description"]
        page.fill("#system", json.dumps({**spec["system"], "springs": []}))
        page.wait_for_function("() => ![...document.querySelectorAll('#method option')]"
                               ".some(o => o.value === 'newmark')", timeout=30_000)
        assert page.input_value("#method") == "3s"
        assert offered() == [m["name"] for m in _distinct_methods(module_server)]


def _distinct_methods(server) -> list[dict]:
    """GET /v1/methods, one row per name in its order: the menu's options for any system."""
    rows = server.client.get("/v1/methods").json()
    return [row for i, row in enumerate(rows) if row["name"] not in {r["name"] for r in rows[:i]}]
