"""The web page at / and the API docs at /docs, with every script they load served from here.

No CDN: Plotly's JavaScript comes from the `plotly` package and Swagger UI from `fastapi-offline`'s
copy of it, so both pages work on a lab network without internet. (Not `swagger-ui-bundle`: its
Swagger UI 4.15 cannot render OpenAPI 3.1, which FastAPI writes; it shows "does not specify a
valid version field".) The page itself is static (static/); it
talks to the service only through the public /v1 API.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from fastapi import APIRouter, FastAPI
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.responses import FileResponse, HTMLResponse
from fastapi.staticfiles import StaticFiles

__all__ = ["STATIC_DIR", "mount_assets", "router"]

STATIC_DIR = Path(__file__).resolve().parents[1] / "static"
SWAGGER_URL = "/vendor/swagger-ui"

router = APIRouter(include_in_schema=False)


def _plotly_js() -> Path:
    """plotly.min.js as the plotly package ships it (the file its offline HTML export embeds)."""
    path = Path(str(files("plotly") / "package_data" / "plotly.min.js"))
    if not path.is_file():
        raise RuntimeError(f"the plotly package has no {path}: reinstall raydamp[service]")
    return path


def _swagger_dir() -> Path:
    """Swagger UI 5 (swagger-ui-bundle.js, swagger-ui.css, favicon.png) as fastapi-offline ships it."""
    path = Path(str(files("fastapi_offline") / "static"))
    if not (path / "swagger-ui-bundle.js").is_file():
        raise RuntimeError(f"the fastapi-offline package has no Swagger UI in {path}: reinstall raydamp[service]")
    return path


@router.get("/", response_class=FileResponse)
def page() -> FileResponse:
    return FileResponse(STATIC_DIR / "index.html", media_type="text/html")


@router.get("/vendor/plotly.min.js", response_class=FileResponse)
def plotly_js() -> FileResponse:
    # The file changes only with the package; a day's caching spares reloading 4 MB on every visit.
    return FileResponse(_plotly_js(), media_type="text/javascript", headers={"Cache-Control": "max-age=86400"})


@router.get("/docs", response_class=HTMLResponse)
def docs() -> HTMLResponse:
    return get_swagger_ui_html(openapi_url="/openapi.json", title="raydamp API",
                               swagger_js_url=f"{SWAGGER_URL}/swagger-ui-bundle.js",
                               swagger_css_url=f"{SWAGGER_URL}/swagger-ui.css",
                               swagger_favicon_url=f"{SWAGGER_URL}/favicon.png",
                               # Swagger UI's default sends the spec to validator.swagger.io for a badge.
                               swagger_ui_parameters={"validatorUrl": None})


def mount_assets(app: FastAPI) -> None:
    """The page's own files under /static and Swagger UI's under /vendor/swagger-ui. Both are checked
    here, so a missing asset stops the service at start rather than leaving a blank page."""
    _plotly_js()
    app.mount("/static", StaticFiles(directory=STATIC_DIR), name="static")
    app.mount(SWAGGER_URL, StaticFiles(directory=_swagger_dir()), name="swagger-ui")
