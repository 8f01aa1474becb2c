// Progressive enhancement: everything works without this file. With it, the progress page
// updates in place (announced through its live region) and error summaries take focus.
(function () {
  "use strict";
  const summary = document.getElementById("error-summary");
  if (summary) summary.focus();
  const job = document.getElementById("job");
  if (!job || job.dataset.state !== "running") return;
  const refresh = document.querySelector('meta[http-equiv="refresh"]');
  if (refresh) refresh.remove();
  const progress = document.getElementById("progress");
  const status = document.getElementById("status");
  async function poll() {
    try {
      const response = await fetch("/jobs/" + job.dataset.job + "/status", { cache: "no-store" });
      const data = await response.json();
      if (progress) { progress.max = data.total; progress.value = data.done; progress.textContent = data.done + " of " + data.total; }
      if (status && status.textContent !== data.message) status.textContent = data.message;
      if (data.state === "running") { setTimeout(poll, 700); } else { window.location.reload(); }
    } catch (error) {
      if (status) status.textContent = "Lost contact with the TAMP-OS server; reload the page to try again.";
    }
  }
  setTimeout(poll, 700);
})();
